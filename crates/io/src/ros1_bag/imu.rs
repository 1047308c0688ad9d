//! The ROS 1 serialization of `sensor_msgs/Imu`: little-endian fields one after another, without alignment or an
//! encapsulation header. `Header` is `uint32 seq`, `time stamp` (u32 seconds, u32 nanoseconds) and
//! `string frame_id` (u32 length, then the bytes, no NUL); then `Quaternion orientation`, `float64[9]
//! orientation_covariance`, `Vector3 angular_velocity`, `float64[9] angular_velocity_covariance`, `Vector3
//! linear_acceleration` and `float64[9] linear_acceleration_covariance`: 37 float64 in all. The length is exact,
//! so a message of another layout does not decode.

/// The float64 after the header: orientation (4), its covariance (9), angular velocity (3), its covariance (9),
/// linear acceleration (3), its covariance (9).
const FLOATS: usize = 37;

/// The fields octavar keeps of one message.
#[derive(Debug)]
pub(super) struct Imu<'a> {
    pub(super) sec: u32,
    pub(super) nsec: u32,
    pub(super) frame_id: &'a str,
    /// rad/s.
    pub(super) w: [f64; 3],
    /// m/s^2.
    pub(super) a: [f64; 3],
    pub(super) a_cov0: f64,
}

/// Decode one ROS 1 `sensor_msgs/Imu`.
///
/// # Errors
/// What is wrong, as text: a message shorter or longer than the layout, a frame_id that is not UTF-8.
pub(super) fn decode_imu(data: &[u8]) -> Result<Imu<'_>, String> {
    let u32_at = |at: usize| data.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let (Some(sec), Some(nsec), Some(len)) = (u32_at(4), u32_at(8), u32_at(12)) else {
        return Err(format!("{} bytes, shorter than a Header", data.len()));
    };
    let want = 16 + len as u64 + 8 * FLOATS as u64;
    if data.len() as u64 != want {
        return Err(format!(
            "{} bytes where a message with a {len}-byte frame_id has {want} (a different message layout?)",
            data.len()
        ));
    }
    let end = 16 + len as usize;
    let frame_id = std::str::from_utf8(&data[16..end]).map_err(|e| format!("header.frame_id is not UTF-8: {e}"))?;
    let f = |i: usize| {
        let at = end + 8 * i;
        f64::from_le_bytes(data[at..at + 8].try_into().expect("8 bytes, the length being checked"))
    };
    Ok(Imu { sec, nsec, frame_id, w: [f(13), f(14), f(15)], a: [f(25), f(26), f(27)], a_cov0: f(28) })
}

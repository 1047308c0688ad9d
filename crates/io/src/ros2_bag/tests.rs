//! The CDR decoding of hand-built `sensor_msgs/msg/Imu` messages, and what is refused as not one.

use super::*;

/// A CDR_LE `sensor_msgs/msg/Imu` written byte by byte: the encapsulation header, then fields aligned to their
/// size counted from after the header.
fn hand_built(frame_id: &str, w: [f64; 3]) -> Vec<u8> {
    let mut b = vec![0x00, 0x01, 0x00, 0x00];
    let body = |b: &Vec<u8>| b.len() - 4;
    b.extend(1_700_000_123i32.to_le_bytes()); // stamp.sec
    b.extend(456_789_012u32.to_le_bytes()); // stamp.nanosec
    b.extend((frame_id.len() as u32 + 1).to_le_bytes());
    b.extend(frame_id.as_bytes());
    b.push(0);
    while body(&b) % 8 != 0 {
        b.push(0xAA); // padding before the first float64 (its content is not read)
    }
    fn f(b: &mut Vec<u8>, v: f64) {
        b.extend(v.to_le_bytes());
    }
    for v in [0.1, 0.2, 0.3, 0.9] {
        f(&mut b, v); // orientation
    }
    for i in 0..9 {
        f(&mut b, i as f64); // orientation_covariance
    }
    for v in w {
        f(&mut b, v);
    }
    for i in 0..9 {
        f(&mut b, 10.0 + i as f64);
    }
    for v in [0.0, 0.0, 9.81] {
        f(&mut b, v);
    }
    for i in 0..9 {
        f(&mut b, 20.0 + i as f64);
    }
    b
}

#[test]
fn decodes_a_hand_built_message() {
    for frame in ["imu_link", "", "abc", "imu"] {
        let b = hand_built(frame, [0.01, -0.02, 1.5e-4]);
        let m = decode_imu(&b).unwrap();
        assert_eq!(m.header.stamp, msg::Time { sec: 1_700_000_123, nanosec: 456_789_012 });
        assert_eq!(m.header.frame_id, frame);
        assert_eq!(m.orientation, msg::Quaternion { x: 0.1, y: 0.2, z: 0.3, w: 0.9 });
        assert_eq!(m.orientation_covariance[8], 8.0);
        assert_eq!(m.angular_velocity, msg::Vector3 { x: 0.01, y: -0.02, z: 1.5e-4 });
        assert_eq!(m.angular_velocity_covariance[0], 10.0);
        assert_eq!(m.linear_acceleration.z, 9.81);
        assert_eq!(m.linear_acceleration_covariance[8], 28.0);
    }
    // Big-endian: the same fields, each byte-swapped.
    let mut be = vec![0x00, 0x00, 0x00, 0x00];
    be.extend(7i32.to_be_bytes());
    be.extend(8u32.to_be_bytes());
    be.extend(1u32.to_be_bytes());
    be.extend([0, 0, 0, 0]); // the empty string's NUL and padding to 8
    for i in 0..(4 + 9 + 3 + 9 + 3 + 9) {
        be.extend((i as f64).to_be_bytes());
    }
    let m = decode_imu(&be).unwrap();
    assert_eq!((m.header.stamp.sec, m.header.stamp.nanosec), (7, 8));
    assert_eq!(m.angular_velocity, msg::Vector3 { x: 13.0, y: 14.0, z: 15.0 });
}

#[test]
fn rejects_what_is_not_an_imu() {
    let b = hand_built("imu_link", [1.0, 2.0, 3.0]);
    assert!(decode_imu(&b[..3]).unwrap_err().contains("shorter than"));
    assert!(decode_imu(&b[..b.len() - 1]).is_err());
    assert!(decode_imu(&b[..40]).is_err());
    let mut xcdr2 = b.clone();
    xcdr2[1] = 0x07;
    assert!(decode_imu(&xcdr2).unwrap_err().contains("not plain CDR"));
    let mut longer = b.clone();
    longer.extend([0u8; 16]);
    assert!(decode_imu(&longer).unwrap_err().contains("left over"));
    // A string length past the end of the message.
    let mut bad = b;
    bad[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(decode_imu(&bad).is_err());
}

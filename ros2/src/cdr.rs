//! CDR payloads as rmw_zenoh sends them: a 4-byte encapsulation header (CDR, little or big
//! endian) and the message in plain CDR (the `cdr-encoding` crate does the encoding).

use cdr_encoding::{from_bytes, to_vec};
use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::error::Ros2Error;
use crate::msgs::RosMessage;

/// Largest payload decoded: the messages of a body are a few hundred bytes.
pub const MAX_PAYLOAD: usize = 64 * 1024;
/// Encapsulation header: plain CDR, little endian, no options.
const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];
/// Encapsulation header: plain CDR, big endian.
const CDR_BE: [u8; 2] = [0x00, 0x00];

/// Encodes a message with its encapsulation header (little endian, what ROS 2 sends).
pub fn encode<T: RosMessage>(msg: &T) -> Result<Vec<u8>, Ros2Error> {
    encode_named(T::TYPE, msg)
}

/// [`encode`] for a type without a fixed hash (an action's service messages); `name` is for errors.
pub fn encode_named<T: Serialize>(name: &str, msg: &T) -> Result<Vec<u8>, Ros2Error> {
    let body = to_vec::<T, byteorder::LittleEndian>(msg).map_err(|e| Ros2Error::Encode { name: name.into(), source: e.into() })?;
    let mut out = Vec::with_capacity(CDR_LE.len() + body.len());
    out.extend_from_slice(&CDR_LE);
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes a payload: checks its size and header, then the message. Any problem is an error
/// naming the type, never a panic.
pub fn decode<T: RosMessage>(bytes: &[u8]) -> Result<T, Ros2Error> {
    decode_named(T::TYPE, bytes)
}

/// [`decode`] for a type without a fixed hash; `name` is for errors. Bytes after the message
/// are ignored, so a prefix of a longer message can be read (the first fields of a result whose
/// tail differs between releases).
pub fn decode_named<T: DeserializeOwned>(name: &str, bytes: &[u8]) -> Result<T, Ros2Error> {
    let bad = |why: String| Ros2Error::Decode { name: name.into(), source: why.into() };
    if bytes.len() > MAX_PAYLOAD {
        return Err(bad(format!("{} bytes (at most {MAX_PAYLOAD})", bytes.len())));
    }
    if bytes.len() < 4 {
        return Err(bad(format!("{} bytes: shorter than the encapsulation header", bytes.len())));
    }
    let (header, body) = bytes.split_at(4);
    let decoded = if header[..2] == CDR_LE[..2] {
        from_bytes::<T, byteorder::LittleEndian>(body)
    } else if header[..2] == CDR_BE {
        from_bytes::<T, byteorder::BigEndian>(body)
    } else {
        return Err(bad(format!("unknown encapsulation {:02x}{:02x} (plain CDR only)", header[0], header[1])));
    };
    decoded.map(|(msg, _)| msg).map_err(|e| Ros2Error::Decode { name: name.into(), source: e.into() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::*;
    use proptest::prelude::*;

    #[test]
    fn twist_is_the_48_bytes_ros_sends() {
        let bytes = encode(&Twist::planar(0.5, -0.25)).expect("encode");
        assert_eq!(bytes.len(), 4 + 48);
        assert_eq!(&bytes[..4], &CDR_LE);
        assert_eq!(&bytes[4..12], &0.5f64.to_le_bytes());
        assert_eq!(&bytes[44..52], &(-0.25f64).to_le_bytes());
        assert_eq!(decode::<Twist>(&bytes).expect("decode"), Twist::planar(0.5, -0.25));
    }

    #[test]
    fn odometry_round_trip_with_alignment() {
        let mut o = Odometry::default();
        o.header.frame_id = "odom".into(); // 4 + 5 bytes: the next f64 needs padding
        o.header.stamp = Time { sec: 12, nanosec: 5 };
        o.child_frame_id = "base_link".into();
        o.pose.pose.position.x = 1.5;
        o.pose.pose.orientation = Quaternion::from_yaw(0.3);
        o.twist.twist = Twist::planar(0.2, 0.1);
        o.pose.covariance[35] = 0.01;
        let bytes = encode(&o).expect("encode");
        assert_eq!(decode::<Odometry>(&bytes).expect("decode"), o);
    }

    #[test]
    fn bad_payloads_are_errors() {
        assert!(decode::<Twist>(&[]).is_err());
        assert!(decode::<Twist>(&[0, 1, 0, 0, 1, 2]).is_err(), "truncated");
        assert!(decode::<Twist>(&[7, 7, 0, 0]).is_err(), "unknown encapsulation");
        assert!(decode::<Twist>(&vec![0u8; MAX_PAYLOAD + 1]).is_err(), "oversized");
        // A string length far beyond the payload.
        let mut o = encode(&Odometry::default()).expect("encode");
        o[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode::<Odometry>(&o).is_err());
    }

    proptest! {
        #[test]
        fn any_bytes_decode_or_fail_cleanly(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let _ = decode::<Odometry>(&bytes);
            let _ = decode::<Twist>(&bytes);
            let _ = decode::<PoseWithCovarianceStamped>(&bytes);
        }
    }
}

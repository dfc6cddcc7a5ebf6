//! Payload codecs with their size limits: JSON for everything but telemetry, which is bincode
//! behind a magic prefix. Decoding never panics and never allocates more than the limit.

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::error::ProtoError;
use crate::robot::Telemetry;

/// Largest JSON payload we decode unless a smaller limit applies: a whole recipe and a mission's
/// plans fit many times over.
pub const JSON_MAX_BYTES: usize = 4 << 20;
/// Largest telemetry payload we accept: a garbage length prefix cannot make us allocate more.
pub const TELEMETRY_MAX_BYTES: usize = 64 * 1024;
/// Prefix of a bincode telemetry payload: protocol name and version.
pub const TELEMETRY_MAGIC: [u8; 4] = *b"MRM3";
/// Media type of every JSON payload.
pub const JSON: &str = "application/json";

/// Parses a JSON payload of at most [`JSON_MAX_BYTES`], with the type's name in the error.
pub fn from_json<T: DeserializeOwned>(what: &str, bytes: &[u8]) -> Result<T, ProtoError> {
    from_json_max(what, bytes, JSON_MAX_BYTES)
}

/// Parses a JSON payload of at most `max` bytes.
pub fn from_json_max<T: DeserializeOwned>(what: &str, bytes: &[u8], max: usize) -> Result<T, ProtoError> {
    if bytes.len() > max {
        return Err(ProtoError::decode(what, format!("{} bytes, more than the {max} accepted", bytes.len())));
    }
    serde_json::from_slice(bytes).map_err(|e| ProtoError::decode(what, e))
}

/// Serialises to JSON. Our wire types always serialise; a failure is reported, not unwrapped.
pub fn to_json<T: Serialize>(v: &T) -> Result<Vec<u8>, ProtoError> {
    serde_json::to_vec(v).map_err(ProtoError::encode)
}

fn wire_config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<TELEMETRY_MAX_BYTES>()
}

/// Encodes telemetry: magic, then bincode (standard config, size-limited).
pub fn encode_telemetry(t: &Telemetry) -> Result<Vec<u8>, ProtoError> {
    let mut out = TELEMETRY_MAGIC.to_vec();
    let body = bincode::serde::encode_to_vec(t, wire_config()).map_err(ProtoError::encode)?;
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes telemetry; any foreign or corrupt payload is an error, never a panic.
pub fn decode_telemetry(bytes: &[u8]) -> Result<Telemetry, ProtoError> {
    if bytes.len() > TELEMETRY_MAX_BYTES {
        return Err(ProtoError::decode("telemetry", format!("{} bytes", bytes.len())));
    }
    let body = bytes.strip_prefix(&TELEMETRY_MAGIC[..]).ok_or_else(|| ProtoError::decode("telemetry", "no MRM3 prefix"))?;
    let (t, used): (Telemetry, usize) = bincode::serde::decode_from_slice(body, wire_config()).map_err(|e| ProtoError::decode("telemetry", e))?;
    if used != body.len() {
        return Err(ProtoError::decode("telemetry", format!("{} trailing bytes", body.len() - used)));
    }
    if !(t.pose.x.is_finite() && t.pose.y.is_finite() && t.pose.theta.is_finite()) {
        return Err(ProtoError::decode("telemetry", "non-finite pose"));
    }
    crate::keys::validate_id(&t.id).map_err(|e| ProtoError::decode("telemetry", e))?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::{Behaviour, Pose, Progress, RobotCommand, Velocity};
    use proptest::prelude::*;

    fn sample() -> Telemetry {
        Telemetry {
            id: "r1".into(),
            seq: 7,
            t: 1.5,
            pose: Pose { x: 1.0, y: -2.0, theta: 0.3 },
            velocity: Velocity { v: 0.5, omega: 0.1 },
            behaviour: Behaviour::Navigate { x: 3.0, y: 4.0 },
            mission: Some("patrol-1".into()),
            progress: Some(Progress {
                mission: "patrol-1".into(),
                epoch: 3,
                step: 4,
                round: 1,
                syncs_passed: 5,
                sync_msgs: 6,
                waiting: Some((2, 1)),
                sync_wait_s: 1.5,
                done: false,
            }),
            admitted: vec!["patrol-1".into()],
            stuck: Some("Nav2 rejected the goal".into()),
            info_rev: 0,
        }
    }

    #[test]
    fn telemetry_round_trips() {
        let t = sample();
        let bytes = encode_telemetry(&t).expect("encode");
        assert_eq!(&bytes[..4], b"MRM3");
        assert_eq!(decode_telemetry(&bytes).expect("decode"), t);
    }

    #[test]
    fn telemetry_rejects_foreign_truncated_and_bad_ids() {
        assert!(decode_telemetry(b"").is_err());
        assert!(decode_telemetry(b"{\"id\":\"r1\"}").is_err());
        let bytes = encode_telemetry(&sample()).expect("encode");
        for cut in 4..bytes.len() {
            assert!(decode_telemetry(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode_telemetry(&longer).is_err());
        let mut bad = sample();
        bad.id = "a/b".into();
        assert!(decode_telemetry(&encode_telemetry(&bad).expect("encode")).is_err());
    }

    #[test]
    fn json_is_size_limited() {
        let big = vec![b' '; 100];
        assert!(from_json_max::<u32>("n", &big, 10).expect_err("too big").to_string().contains("more than the 10"));
        assert_eq!(from_json_max::<u32>("n", b"7", 10).expect("small"), 7);
    }

    proptest! {
        #[test]
        fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode_telemetry(&bytes);
            let mut with_magic = TELEMETRY_MAGIC.to_vec();
            with_magic.extend_from_slice(&bytes);
            let _ = decode_telemetry(&with_magic);
            let _ = from_json::<RobotCommand>("cmd", &bytes);
        }
    }
}

//! Payload codecs with their size limits: JSON for everything but telemetry, which is bincode
//! behind a magic prefix; a large JSON payload that only the fleet reads (a chain message, a
//! planner's answer) travels zstd-compressed. Decoding never panics and never allocates more than
//! the limit.

use std::io::Read;

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
pub const TELEMETRY_MAGIC: [u8; 4] = *b"MRM6";
/// Media type of every JSON payload.
pub const JSON: &str = "application/json";

/// Media type of a compressed JSON payload: a zstd frame of the JSON.
pub const PACKED: &str = "application/zstd";
/// A JSON payload longer than this is sent compressed by [`to_json_packed`]: a plan of a few
/// hundred robots would pass Zenoh's message limit (1 MiB by default) as plain JSON.
pub const PACK_OVER: usize = 64 * 1024;
/// An answer to anyone (the operator API) longer than this is sent compressed: only an answer
/// that would come near the message limit (a mission's plans, hundreds of robots), so that a
/// client of the API reads plain JSON otherwise.
pub const ANSWER_PACK_OVER: usize = 512 * 1024;
/// How a zstd frame begins (its magic number, little-endian); no JSON text begins so.
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];
/// zstd's level for packing: its fastest; plans repeat themselves robot after robot.
const PACK_LEVEL: i32 = 1;
/// The largest window (log2 bytes) a packed payload may ask its decoder for: what our packing
/// uses, with room, and no more — a frame asking for more is refused instead of allocated.
const PACK_WINDOW_LOG: u32 = 23;

/// Parses a JSON payload of at most [`JSON_MAX_BYTES`], with the type's name in the error.
pub fn from_json<T: DeserializeOwned>(what: &str, bytes: &[u8]) -> Result<T, ProtoError> {
    from_json_max(what, bytes, JSON_MAX_BYTES)
}

/// Parses a JSON payload of at most `max` bytes, plain or packed ([`to_json_packed`]: then at
/// most `max` bytes once unpacked).
pub fn from_json_max<T: DeserializeOwned>(what: &str, bytes: &[u8], max: usize) -> Result<T, ProtoError> {
    if bytes.len() > max {
        return Err(ProtoError::decode(what, format!("{} bytes, more than the {max} accepted", bytes.len())));
    }
    if is_packed(bytes) {
        let json = unpack(what, bytes, max)?;
        return serde_json::from_slice(&json).map_err(|e| ProtoError::decode(what, e));
    }
    serde_json::from_slice(bytes).map_err(|e| ProtoError::decode(what, e))
}

/// Serialises to JSON. Our wire types always serialise; a failure is reported, not unwrapped.
pub fn to_json<T: Serialize>(v: &T) -> Result<Vec<u8>, ProtoError> {
    serde_json::to_vec(v).map_err(ProtoError::encode)
}

/// Serialises to JSON, compressed (a zstd frame) when longer than [`PACK_OVER`]. For payloads
/// only the fleet reads; [`from_json`] takes both. Any zstd tool opens one (`zstd -d`, Python's
/// `zstandard.decompress`).
pub fn to_json_packed<T: Serialize>(v: &T) -> Result<Vec<u8>, ProtoError> {
    to_json_packed_over(v, PACK_OVER)
}

/// Serialises to JSON, compressed when longer than `over` bytes.
pub fn to_json_packed_over<T: Serialize>(v: &T, over: usize) -> Result<Vec<u8>, ProtoError> {
    let json = to_json(v)?;
    if json.len() <= over {
        return Ok(json);
    }
    zstd::bulk::compress(&json, PACK_LEVEL).map_err(ProtoError::encode)
}

/// Whether a payload is packed JSON (a zstd frame) rather than plain.
pub fn is_packed(bytes: &[u8]) -> bool {
    bytes.starts_with(&ZSTD_MAGIC)
}

/// The media type of a JSON payload as sent: [`JSON`] or, packed, [`PACKED`].
pub fn media_type(bytes: &[u8]) -> &'static str {
    if is_packed(bytes) {
        PACKED
    } else {
        JSON
    }
}

/// The JSON inside a packed payload: at most `max` bytes of it are read, with a decoder window of
/// at most 2^[`PACK_WINDOW_LOG`] bytes, so a hostile frame allocates no more than that.
fn unpack(what: &str, bytes: &[u8], max: usize) -> Result<Vec<u8>, ProtoError> {
    let bad = |e: std::io::Error| ProtoError::decode(what, format!("packed payload: {e}"));
    let mut decoder = zstd::stream::read::Decoder::with_buffer(bytes).map_err(bad)?.single_frame();
    decoder.window_log_max(PACK_WINDOW_LOG).map_err(bad)?;
    let mut json = Vec::new();
    decoder.take(max as u64 + 1).read_to_end(&mut json).map_err(bad)?;
    if json.len() > max {
        return Err(ProtoError::decode(what, format!("packed payload unpacks to more than the {max} bytes accepted")));
    }
    Ok(json)
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
    let body = bytes.strip_prefix(&TELEMETRY_MAGIC[..]).ok_or_else(|| ProtoError::decode("telemetry", "no MRM6 prefix"))?;
    let (t, used): (Telemetry, usize) = bincode::serde::decode_from_slice(body, wire_config()).map_err(|e| ProtoError::decode("telemetry", e))?;
    if used != body.len() {
        return Err(ProtoError::decode("telemetry", format!("{} trailing bytes", body.len() - used)));
    }
    if !(t.pose.x.is_finite() && t.pose.y.is_finite() && t.pose.theta.is_finite()) {
        return Err(ProtoError::decode("telemetry", "non-finite pose"));
    }
    crate::keys::validate_id(t.id.as_str()).map_err(|e| ProtoError::decode("telemetry", e))?;
    if let Some(b) = &t.battery {
        b.check().map_err(|e| ProtoError::decode("telemetry", e))?;
    }
    if let Some(v) = &t.vehicle {
        v.check().map_err(|e| ProtoError::decode("telemetry", e))?;
    }
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
                traffic_wait_s: 2.5,
                done: false,
            }),
            admitted: vec!["patrol-1".into()],
            stuck: Some("Nav2 rejected the goal".into()),
            info_rev: 0,
            battery: Some(crate::robot::BatteryState { charge: 0.5, charging: true, reach_m: Some(120.0) }),
            vehicle: Some(Box::new(crate::robot::VehicleState {
                last_node: "pantry".into(),
                driving: true,
                paused: false,
                errors: vec![crate::robot::VehicleError { kind: "noRouteError".into(), level: "WARNING".into(), description: None }],
                actions: vec![crate::robot::VehicleAction { id: "a1".into(), kind: Some("startPause".into()), status: "RUNNING".into() }],
            })),
        }
    }

    #[test]
    fn telemetry_round_trips() {
        let t = sample();
        let bytes = encode_telemetry(&t).expect("encode");
        assert_eq!(&bytes[..4], b"MRM6");
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
        // A battery state no battery has: refused with what is wrong.
        for (charge, reach) in [(1.5, Some(1.0)), (f64::NAN, None), (0.5, Some(-1.0)), (0.5, Some(f64::INFINITY))] {
            let mut bad = sample();
            bad.battery = Some(crate::robot::BatteryState { charge, charging: false, reach_m: reach });
            let e = decode_telemetry(&encode_telemetry(&bad).expect("encode")).expect_err("refused");
            assert!(e.to_string().contains("battery"), "{e}");
        }
        // A vehicle's state over its bounds: refused.
        let mut bad = sample();
        if let Some(v) = bad.vehicle.as_mut() {
            v.last_node = "n".repeat(crate::robot::MAX_VEHICLE_WORD + 1);
        }
        assert!(decode_telemetry(&encode_telemetry(&bad).expect("encode")).expect_err("refused").to_string().contains("vehicle"));
        let mut bad = sample();
        if let Some(v) = bad.vehicle.as_mut() {
            v.errors = vec![v.errors[0].clone(); crate::robot::MAX_VEHICLE_ITEMS + 1];
        }
        assert!(decode_telemetry(&encode_telemetry(&bad).expect("encode")).expect_err("refused").to_string().contains("vehicle"));
        // An older robot's telemetry (the version before vehicles' states) is named as foreign.
        let mut old = bytes.clone();
        old[..4].copy_from_slice(b"MRM5");
        assert!(decode_telemetry(&old).expect_err("old").to_string().contains("MRM6"));
    }

    #[test]
    fn json_is_size_limited() {
        let big = vec![b' '; 100];
        assert!(from_json_max::<u32>("n", &big, 10).expect_err("too big").to_string().contains("more than the 10"));
        assert_eq!(from_json_max::<u32>("n", b"7", 10).expect("small"), 7);
    }

    /// A payload of `n` robots' worth of repetitive JSON, as a plan is.
    fn plans(n: usize) -> Vec<serde_json::Value> {
        (0..n)
            .map(|i| serde_json::json!({"robot": format!("r{i}"), "steps": [{"navigate": {"x": 1.25, "y": i as f64 * 0.5}}, {"sync": {"point": 3}}]}))
            .collect()
    }

    #[test]
    fn a_large_payload_is_packed_and_a_small_one_stays_json() {
        let small = plans(10);
        assert_eq!(to_json_packed(&small).expect("encode"), to_json(&small).expect("encode"));
        let middling = plans(2_000);
        let json = to_json(&middling).expect("encode");
        assert!(json.len() > PACK_OVER && json.len() < ANSWER_PACK_OVER);
        assert_eq!(to_json_packed_over(&middling, ANSWER_PACK_OVER).expect("encode"), json);
        assert!(is_packed(&to_json_packed(&middling).expect("encode")));
        assert_eq!(media_type(&to_json_packed(&small).expect("encode")), JSON);
        let large = plans(5_000);
        let json = to_json(&large).expect("encode");
        let packed = to_json_packed(&large).expect("encode");
        assert!(json.len() > PACK_OVER && packed.len() * 10 < json.len(), "{} → {}", json.len(), packed.len());
        assert_eq!(media_type(&packed), PACKED);
        assert_eq!(from_json::<Vec<serde_json::Value>>("plans", &packed).expect("decode"), large);
        assert_eq!(from_json::<Vec<serde_json::Value>>("plans", &json).expect("decode"), large);
    }

    #[test]
    fn a_packed_payload_that_unpacks_past_the_limit_is_refused_without_reading_it_all() {
        // 64 MiB of spaces in a frame of a few KiB: a bomb, read up to the limit and refused.
        let bomb = zstd::bulk::compress(&vec![b' '; 64 << 20], 19).expect("compress");
        assert!(bomb.len() < 64 << 10, "{}", bomb.len());
        let e = from_json::<u32>("n", &bomb).expect_err("too large");
        assert!(e.to_string().contains(&format!("unpacks to more than the {JSON_MAX_BYTES}")), "{e}");
        let packed = to_json_packed(&plans(5_000)).expect("encode");
        let e = from_json_max::<Vec<serde_json::Value>>("plans", &packed, 100_000).expect_err("too large");
        assert!(e.to_string().contains("unpacks to more than the 100000"), "{e}");
    }

    #[test]
    fn a_packed_payload_asking_for_a_huge_window_or_cut_short_is_refused() {
        // 16 MiB in one frame asks its decoder for a 16 MiB window: refused before any is read.
        let mut wide = zstd::bulk::Compressor::new(1).expect("compressor");
        wide.set_parameter(zstd::zstd_safe::CParameter::WindowLog(27)).expect("window");
        let wide = wide.compress(&vec![b' '; 16 << 20]).expect("compress");
        let e = from_json_max::<u32>("n", &wide, 64 << 20).expect_err("window too large");
        assert!(e.to_string().contains("packed payload") && !e.to_string().contains("unpacks"), "{e}");
        let packed = to_json_packed(&plans(5_000)).expect("encode");
        for cut in [4, 10, packed.len() / 2, packed.len() - 1] {
            assert!(from_json::<Vec<serde_json::Value>>("plans", &packed[..cut]).is_err(), "cut at {cut}");
        }
    }

    proptest! {
        #[test]
        fn decode_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode_telemetry(&bytes);
            let mut with_magic = TELEMETRY_MAGIC.to_vec();
            with_magic.extend_from_slice(&bytes);
            let _ = decode_telemetry(&with_magic);
            let _ = from_json::<RobotCommand>("cmd", &bytes);
            let mut packed = ZSTD_MAGIC.to_vec();
            packed.extend_from_slice(&bytes);
            let _ = from_json::<RobotCommand>("cmd", &packed);
        }
    }
}

//! The mrmm wire protocol: every key expression and every payload type, built and parsed here only.
//!
//! # Key space
//!
//! | key | kind | payload | encoding |
//! |---|---|---|---|
//! | `mrmm/robots/<id>/alive` | liveliness token | none | — |
//! | `mrmm/robots/<id>/info` | queryable on the robot | [`RobotInfo`] | JSON |
//! | `mrmm/robots/<id>/telemetry` | publication by the robot | [`Telemetry`] | bincode behind [`TELEMETRY_MAGIC`] |
//! | `mrmm/robots/<id>/cmd` | queryable on the robot | query: [`RobotCommand`], reply: [`CommandAck`] | JSON |
//! | `mrmm/system/status` | queryable on the system manager | [`SystemStatus`] | JSON |
//! | `mrmm/system/robots` | queryable on the system manager | `[`[`RobotView`]`]` | JSON |
//! | `mrmm/system/robots/<id>` | queryable on the system manager | [`RobotView`] | JSON |
//! | `mrmm/system/cmd/robot/goto` | queryable on the system manager | query: [`GotoRequest`], reply: [`CommandAck`] | JSON |
//!
//! Every error reply on an operator key is a Zenoh reply error whose payload is [`ErrorReply`]
//! (`{"error": "…"}`), JSON.
//!
//! Robot ids are single key chunks: 1 to 64 characters of `[A-Za-z0-9_-]`.

use serde::{Deserialize, Serialize};

use crate::error::PeerError;

/// First chunk of every mrmm key.
pub const ROOT: &str = "mrmm";
/// Liveliness tokens of all robots.
pub const ALL_ROBOTS_ALIVE: &str = "mrmm/robots/*/alive";
/// Telemetry of all robots.
pub const ALL_ROBOTS_TELEMETRY: &str = "mrmm/robots/*/telemetry";
/// Everything the system manager answers.
pub const SYSTEM_ALL: &str = "mrmm/system/**";
/// Fleet summary.
pub const SYSTEM_STATUS: &str = "mrmm/system/status";
/// Fleet table.
pub const SYSTEM_ROBOTS: &str = "mrmm/system/robots";
/// Operator command: drive a robot to a point.
pub const SYSTEM_CMD_GOTO: &str = "mrmm/system/cmd/robot/goto";
/// Media type of every JSON payload.
pub const JSON: &str = "application/json";
/// Prefix of a bincode telemetry payload: protocol name and version.
pub const TELEMETRY_MAGIC: [u8; 4] = *b"MRM1";

/// Checks that `id` can be used as a robot id (one key chunk, no wildcard or separator).
pub fn validate_id(id: &str) -> Result<(), PeerError> {
    let ok_len = !id.is_empty() && id.len() <= 64;
    let ok_chars = id
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok_len && ok_chars {
        Ok(())
    } else {
        Err(PeerError::BadId(id.to_string()))
    }
}

/// `mrmm/robots/<id>/alive`
pub fn robot_alive(id: &str) -> String {
    format!("{ROOT}/robots/{id}/alive")
}
/// `mrmm/robots/<id>/info`
pub fn robot_info(id: &str) -> String {
    format!("{ROOT}/robots/{id}/info")
}
/// `mrmm/robots/<id>/telemetry`
pub fn robot_telemetry(id: &str) -> String {
    format!("{ROOT}/robots/{id}/telemetry")
}
/// `mrmm/robots/<id>/cmd`
pub fn robot_cmd(id: &str) -> String {
    format!("{ROOT}/robots/{id}/cmd")
}
/// `mrmm/system/robots/<id>`
pub fn system_robot(id: &str) -> String {
    format!("{SYSTEM_ROBOTS}/{id}")
}

/// What a robot key is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobotTopic {
    Alive,
    Info,
    Telemetry,
    Cmd,
}

/// Parses `mrmm/robots/<id>/<topic>` into the id and the topic.
pub fn parse_robot_key(key: &str) -> Option<(&str, RobotTopic)> {
    let mut parts = key.split('/');
    if parts.next()? != ROOT || parts.next()? != "robots" {
        return None;
    }
    let id = parts.next()?;
    let topic = match parts.next()? {
        "alive" => RobotTopic::Alive,
        "info" => RobotTopic::Info,
        "telemetry" => RobotTopic::Telemetry,
        "cmd" => RobotTopic::Cmd,
        _ => return None,
    };
    if parts.next().is_some() || validate_id(id).is_err() {
        return None;
    }
    Some((id, topic))
}

/// An operator request addressed to the system manager.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SystemKey {
    Status,
    Robots,
    Robot(String),
    CmdGoto,
}

/// Parses a key under `mrmm/system/`.
pub fn parse_system_key(key: &str) -> Option<SystemKey> {
    let rest = key.strip_prefix("mrmm/system/")?;
    match rest {
        "status" => Some(SystemKey::Status),
        "robots" => Some(SystemKey::Robots),
        "cmd/robot/goto" => Some(SystemKey::CmdGoto),
        _ => {
            let id = rest.strip_prefix("robots/")?;
            validate_id(id).ok()?;
            Some(SystemKey::Robot(id.to_string()))
        }
    }
}

/// A planar pose: position in metres, heading in radians (counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

/// Linear (m/s) and angular (rad/s) velocity.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct Velocity {
    pub v: f64,
    pub omega: f64,
}

/// What a robot is doing right now. Externally tagged (bincode cannot carry internal tags):
/// JSON `"hold"` or `{"navigate": {"x": 1.0, "y": 2.0}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Behaviour {
    /// Standing still.
    Hold,
    /// Driving to a point.
    Navigate { x: f64, y: f64 },
}

impl Behaviour {
    /// Short human-readable form for tables.
    pub fn describe(&self) -> String {
        match self {
            Behaviour::Hold => "hold".to_string(),
            Behaviour::Navigate { x, y } => format!("goto({x:.1},{y:.1})"),
        }
    }
}

/// Periodic state of one robot, on `mrmm/robots/<id>/telemetry`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    pub id: String,
    /// Sequence number, +1 per publication.
    pub seq: u64,
    /// Simulated time of the robot, seconds since it started.
    pub t: f64,
    pub pose: Pose,
    pub velocity: Velocity,
    pub behaviour: Behaviour,
    pub mission: Option<String>,
}

/// Largest telemetry payload we accept: a garbage length prefix cannot make us allocate more.
pub const TELEMETRY_MAX_BYTES: usize = 64 * 1024;

fn wire_config() -> impl bincode::config::Config {
    bincode::config::standard().with_limit::<TELEMETRY_MAX_BYTES>()
}

/// Encodes telemetry: magic, then bincode (standard config, size-limited).
pub fn encode_telemetry(t: &Telemetry) -> Result<Vec<u8>, PeerError> {
    let mut out = TELEMETRY_MAGIC.to_vec();
    let body = bincode::serde::encode_to_vec(t, wire_config())
        .map_err(|e| PeerError::Encode(e.to_string()))?;
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes telemetry; any foreign or corrupt payload is an error, never a panic.
pub fn decode_telemetry(bytes: &[u8]) -> Result<Telemetry, PeerError> {
    let body = bytes
        .strip_prefix(&TELEMETRY_MAGIC[..])
        .ok_or_else(|| PeerError::Decode("telemetry without the MRM1 prefix".into()))?;
    let (t, used): (Telemetry, usize) =
        bincode::serde::decode_from_slice(body, wire_config())
            .map_err(|e| PeerError::Decode(format!("telemetry: {e}")))?;
    if used != body.len() {
        return Err(PeerError::Decode(format!(
            "telemetry: {} trailing bytes",
            body.len() - used
        )));
    }
    if !(t.pose.x.is_finite() && t.pose.y.is_finite() && t.pose.theta.is_finite()) {
        return Err(PeerError::Decode("telemetry: non-finite pose".into()));
    }
    Ok(t)
}

/// What a robot says about itself when it registers (answer of `mrmm/robots/<id>/info`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotInfo {
    pub id: String,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub capabilities: Vec<String>,
    /// Maximum linear speed, m/s.
    pub max_speed: f64,
    /// Zenoh endpoints the robot listens on.
    pub endpoints: Vec<String>,
}

/// A command to one robot, query payload on `mrmm/robots/<id>/cmd`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
pub enum RobotCommand {
    /// Drive to (x, y) and hold there.
    Goto { x: f64, y: f64 },
    /// Stop where you are.
    Hold,
}

/// Positive answer to a command.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandAck {
    pub ok: bool,
    pub robot: String,
    pub behaviour: Behaviour,
}

/// Operator command `mrmm/system/cmd/robot/goto`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GotoRequest {
    pub robot: String,
    pub x: f64,
    pub y: f64,
}

/// Registry status of a robot as the operator sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RobotStatus {
    /// Alive, in no mission, not moving on an order.
    Idle,
    /// Alive and executing a behaviour or a mission.
    Busy,
    /// Liveliness lost.
    Lost,
}

impl RobotStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            RobotStatus::Idle => "idle",
            RobotStatus::Busy => "busy",
            RobotStatus::Lost => "lost",
        }
    }
}

/// One row of the fleet table (`mrmm/system/robots`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotView {
    pub id: String,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub capabilities: Vec<String>,
    pub status: RobotStatus,
    pub mission: Option<String>,
    pub pose: Option<Pose>,
    /// What the robot reported doing last (`hold`, `goto(x,y)`).
    #[serde(default)]
    pub behaviour: Option<String>,
}

/// Fleet summary (`mrmm/system/status`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystemStatus {
    /// Zenoh id of the system manager's session.
    pub node: String,
    pub uptime_s: f64,
    pub robots_total: usize,
    pub idle: usize,
    pub busy: usize,
    pub lost: usize,
}

/// Error payload of every reply error on an operator key.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReply {
    pub error: String,
}

/// Parses a JSON payload, with the type's name in the error.
pub fn from_json<T: serde::de::DeserializeOwned>(what: &str, bytes: &[u8]) -> Result<T, PeerError> {
    serde_json::from_slice(bytes).map_err(|e| PeerError::Decode(format!("{what}: {e}")))
}

/// Serialises to JSON. Our wire types always serialise; a failure is reported, not unwrapped.
pub fn to_json<T: Serialize>(v: &T) -> Result<Vec<u8>, PeerError> {
    serde_json::to_vec(v).map_err(|e| PeerError::Encode(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
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
        }
    }

    #[test]
    fn telemetry_round_trips() {
        let t = sample();
        let bytes = encode_telemetry(&t).expect("encode");
        assert_eq!(&bytes[..4], b"MRM1");
        assert_eq!(decode_telemetry(&bytes).expect("decode"), t);
    }

    #[test]
    fn telemetry_rejects_foreign_and_truncated() {
        assert!(decode_telemetry(b"").is_err());
        assert!(decode_telemetry(b"{\"id\":\"r1\"}").is_err());
        let bytes = encode_telemetry(&sample()).expect("encode");
        for cut in 4..bytes.len() {
            assert!(decode_telemetry(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode_telemetry(&longer).is_err());
    }

    #[test]
    fn keys_build_and_parse() {
        assert_eq!(robot_alive("r1"), "mrmm/robots/r1/alive");
        assert_eq!(parse_robot_key(&robot_telemetry("r-2")), Some(("r-2", RobotTopic::Telemetry)));
        assert_eq!(parse_robot_key(&robot_cmd("a_b")), Some(("a_b", RobotTopic::Cmd)));
        assert_eq!(parse_robot_key("mrmm/robots/r1/alive/x"), None);
        assert_eq!(parse_robot_key("other/robots/r1/alive"), None);
        assert_eq!(parse_robot_key("mrmm/robots/*/alive"), None);
        assert_eq!(parse_system_key(SYSTEM_ROBOTS), Some(SystemKey::Robots));
        assert_eq!(parse_system_key(&system_robot("r9")), Some(SystemKey::Robot("r9".into())));
        assert_eq!(parse_system_key(SYSTEM_CMD_GOTO), Some(SystemKey::CmdGoto));
        assert_eq!(parse_system_key(SYSTEM_STATUS), Some(SystemKey::Status));
        assert_eq!(parse_system_key("mrmm/system/robots/a/b"), None);
        assert_eq!(parse_system_key("mrmm/system/nope"), None);
    }

    #[test]
    fn ids_are_single_chunks() {
        assert!(validate_id("robot-01_a").is_ok());
        for bad in ["", "a/b", "*", "a b", "é", &"x".repeat(65)] {
            assert!(validate_id(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn commands_are_tagged_json() {
        let c: RobotCommand = from_json("cmd", br#"{"cmd":"goto","x":1,"y":2}"#).expect("goto");
        assert_eq!(c, RobotCommand::Goto { x: 1.0, y: 2.0 });
        assert!(from_json::<RobotCommand>("cmd", br#"{"cmd":"fly"}"#).is_err());
        assert!(from_json::<GotoRequest>("goto", br#"{"robot":"r1","x":1}"#).is_err());
        let v = serde_json::to_value(RobotStatus::Lost).expect("json");
        assert_eq!(v, serde_json::json!("lost"));
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

        #[test]
        fn parse_keys_never_panics(s in "\\PC{0,40}") {
            let _ = parse_robot_key(&s);
            let _ = parse_system_key(&s);
        }
    }
}

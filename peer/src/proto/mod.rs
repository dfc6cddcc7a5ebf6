//! The mrmm wire protocol: every key expression and every payload type, built and parsed here only.
//!
//! # Key space
//!
//! | key | kind | payload | encoding |
//! |---|---|---|---|
//! | `mrmm/robots/<id>/alive` | liveliness token of a robot | — | — |
//! | `mrmm/robots/<id>/info` | queryable on the robot | [`RobotInfo`] | JSON |
//! | `mrmm/robots/<id>/telemetry` | publication by the robot | [`Telemetry`] | bincode behind [`TELEMETRY_MAGIC`] |
//! | `mrmm/robots/<id>/cmd` | queryable on the robot | query [`RobotCommand`], reply [`CommandAck`] | JSON |
//! | `mrmm/team/<mission>/<type>/member/<id>` | liveliness token of a team member | — | — |
//! | `mrmm/team/<mission>/sync/<point>/<round>` | publication by each member at a barrier | [`SyncArrival`] | JSON |
//! | `mrmm/planner/<kind>` | queryable of a planner service (`patrol`, `coverage`) | query [`PlanRequest`], reply `MissionPlan` | JSON |
//! | `mrmm/planner/<kind>/alive/<zid>` | liveliness token of a planner service | — | — |
//! | `mrmm/hosts/<node>/alive` | liveliness token of a mission host | — | — |
//! | `mrmm/hosts/<node>/chain` | publication to a mission host: chain replication of mission managers | `mrmm_manager::host::ChainEnvelope` | JSON |
//! | `mrmm/hosts/<node>/start` | queryable of a mission host | query [`MissionStart`], reply [`MissionView`] once planned | JSON |
//! | `mrmm/missions/<name>/ctl` | queryable of the mission's host | query [`MissionCtl`], reply [`CtlAck`] | JSON |
//! | `mrmm/missions/<name>/view` | queryable of the mission's host | [`MissionView`] with plans | JSON |
//! | `mrmm/missions/<name>/marginal?add=±k` | queryable of the mission's host | [`Marginal`] | JSON |
//! | `mrmm/missions/<name>/status` | publication of the mission's host, 1 Hz | [`MissionView`] | JSON |
//! | `mrmm/agent/advice` | queryable of the advising agent | `[`[`Advice`]`]` standing advice | JSON |
//! | `mrmm/agent/advice/live` | publication of the advising agent | [`AdviceEvent`] | JSON |
//! | `mrmm/system/status` | queryable on the system manager | [`SystemStatus`] | JSON |
//! | `mrmm/system/robots`, `…/robots/<id>` | queryable on the system manager | [`RobotView`] list / one | JSON |
//! | `mrmm/system/missions`, `…/missions/<name>` | queryable on the system manager | [`MissionView`] list / one with plans | JSON |
//! | `mrmm/system/cmd/robot/goto` | queryable on the system manager | query [`GotoRequest`] | JSON |
//! | `mrmm/system/cmd/robot/move` | queryable on the system manager | query [`RobotMove`] | JSON |
//! | `mrmm/system/cmd/mission/create` | queryable on the system manager | query [`MissionCreate`] | JSON |
//! | `mrmm/system/cmd/mission/terminate` | queryable on the system manager | query [`MissionTerminate`] | JSON |
//!
//! Every error reply on an operator key is a Zenoh reply error whose payload is [`ErrorReply`]
//! (`{"error": "…"}`), JSON.
//!
//! Robot ids and mission names are single key chunks: 1 to 64 characters of `[A-Za-z0-9_-]`.

mod agent;
mod mission;
mod operator;
mod robot;
mod team;

use std::collections::BTreeMap;

use mrmm_planner::plan::RobotSpec;
use serde::{Deserialize, Serialize};

use crate::error::PeerError;

pub use agent::*;
pub use mission::*;
pub use operator::*;
pub use robot::*;
pub use team::*;

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
/// Missions table.
pub const SYSTEM_MISSIONS: &str = "mrmm/system/missions";
/// Operator command: drive a robot to a point.
pub const SYSTEM_CMD_GOTO: &str = "mrmm/system/cmd/robot/goto";
/// Operator command: move a robot to another mission.
pub const SYSTEM_CMD_MOVE: &str = "mrmm/system/cmd/robot/move";
/// Operator command: create a mission.
pub const SYSTEM_CMD_CREATE: &str = "mrmm/system/cmd/mission/create";
/// Operator command: terminate a mission.
pub const SYSTEM_CMD_TERMINATE: &str = "mrmm/system/cmd/mission/terminate";
/// Standing advice (queryable).
pub const AGENT_ADVICE: &str = "mrmm/agent/advice";
/// Advice changes (publication).
pub const AGENT_ADVICE_LIVE: &str = "mrmm/agent/advice/live";
/// Status publications of every mission.
pub const ALL_MISSIONS_STATUS: &str = "mrmm/missions/*/status";
/// Liveliness tokens of every mission host.
pub const ALL_HOSTS_ALIVE: &str = "mrmm/hosts/*/alive";
/// Name of the mission host inside central.
pub const CENTRAL_HOST: &str = "central";
/// Media type of every JSON payload.
pub const JSON: &str = "application/json";
/// Prefix of a bincode telemetry payload: protocol name and version.
pub const TELEMETRY_MAGIC: [u8; 4] = *b"MRM2";

/// Checks that `id` can be used as a robot id or mission name (one key chunk, no wildcard).
pub fn validate_id(id: &str) -> Result<(), PeerError> {
    let ok_len = !id.is_empty() && id.len() <= 64;
    let ok_chars = id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
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
/// `mrmm/system/missions/<name>`
pub fn system_mission(name: &str) -> String {
    format!("{SYSTEM_MISSIONS}/{name}")
}
/// `mrmm/team/<subteam>/member/<id>` (subteam = `<mission>/<type>`)
pub fn team_member(subteam: &str, id: &str) -> String {
    format!("{ROOT}/team/{subteam}/member/{id}")
}
/// Every member token of a team: `mrmm/team/<team>/*/member/*`
pub fn team_members(team: &str) -> String {
    format!("{ROOT}/team/{team}/*/member/*")
}
/// `mrmm/team/<team>/sync/<point>/<round>`
pub fn team_sync(team: &str, point: u32, round: u32) -> String {
    format!("{ROOT}/team/{team}/sync/{point}/{round}")
}
/// Every barrier of a team: `mrmm/team/<team>/sync/**`
pub fn team_sync_all(team: &str) -> String {
    format!("{ROOT}/team/{team}/sync/**")
}
/// The robot id of a team member token key.
pub fn parse_team_member(key: &str) -> Option<&str> {
    let id = key.rsplit('/').next()?;
    let rest = key.strip_suffix(id)?.strip_suffix("/member/")?;
    rest.starts_with("mrmm/team/").then_some(id).filter(|id| validate_id(id).is_ok())
}
/// `mrmm/planner/<kind>`
pub fn planner(kind: &str) -> String {
    format!("{ROOT}/planner/{kind}")
}
/// `mrmm/planner/<kind>/alive/<zid>`
pub fn planner_alive(kind: &str, zid: &str) -> String {
    format!("{ROOT}/planner/{kind}/alive/{zid}")
}
/// `mrmm/missions/<name>/marginal`
pub fn mission_marginal(name: &str) -> String {
    format!("{ROOT}/missions/{name}/marginal")
}
/// `mrmm/missions/<name>/ctl`
pub fn mission_ctl(name: &str) -> String {
    format!("{ROOT}/missions/{name}/ctl")
}
/// `mrmm/missions/<name>/view`
pub fn mission_view(name: &str) -> String {
    format!("{ROOT}/missions/{name}/view")
}
/// `mrmm/hosts/<node>/alive`
pub fn host_alive(node: &str) -> String {
    format!("{ROOT}/hosts/{node}/alive")
}
/// `mrmm/hosts/<node>/chain`
pub fn host_chain(node: &str) -> String {
    format!("{ROOT}/hosts/{node}/chain")
}
/// `mrmm/hosts/<node>/start`
pub fn host_start(node: &str) -> String {
    format!("{ROOT}/hosts/{node}/start")
}
/// The node name of a `mrmm/hosts/<node>/alive` key.
pub fn parse_host_alive(key: &str) -> Option<&str> {
    let node = key.strip_prefix("mrmm/hosts/")?.strip_suffix("/alive")?;
    validate_id(node).is_ok().then_some(node)
}
/// `mrmm/missions/<name>/status`
pub fn mission_status(name: &str) -> String {
    format!("{ROOT}/missions/{name}/status")
}
/// The mission name of a `mrmm/missions/<name>/<topic>` key.
pub fn parse_mission_key(key: &str) -> Option<(&str, &str)> {
    let rest = key.strip_prefix("mrmm/missions/")?;
    let (name, topic) = rest.split_once('/')?;
    (validate_id(name).is_ok() && !topic.contains('/')).then_some((name, topic))
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
    Missions,
    Mission(String),
    CmdGoto,
    CmdMove,
    CmdCreate,
    CmdTerminate,
}

/// Parses a key under `mrmm/system/`.
pub fn parse_system_key(key: &str) -> Option<SystemKey> {
    let rest = key.strip_prefix("mrmm/system/")?;
    match rest {
        "status" => Some(SystemKey::Status),
        "robots" => Some(SystemKey::Robots),
        "missions" => Some(SystemKey::Missions),
        "cmd/robot/goto" => Some(SystemKey::CmdGoto),
        "cmd/robot/move" => Some(SystemKey::CmdMove),
        "cmd/mission/create" => Some(SystemKey::CmdCreate),
        "cmd/mission/terminate" => Some(SystemKey::CmdTerminate),
        _ => {
            if let Some(id) = rest.strip_prefix("robots/") {
                validate_id(id).ok()?;
                Some(SystemKey::Robot(id.to_string()))
            } else {
                let name = rest.strip_prefix("missions/")?;
                validate_id(name).ok()?;
                Some(SystemKey::Mission(name.to_string()))
            }
        }
    }
}

/// Query payload of a planner service: a recipe (bank name or XML), overrides, robots.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanRequest {
    pub recipe: String,
    #[serde(default)]
    pub params: BTreeMap<String, String>,
    pub robots: Vec<RobotSpec>,
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
        .ok_or_else(|| PeerError::Decode("telemetry without the MRM2 prefix".into()))?;
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
            progress: Some(Progress {
                mission: "patrol-1".into(),
                epoch: 3,
                step: 4,
                round: 1,
                syncs_passed: 5,
                sync_msgs: 6,
                waiting: Some((2, 1)),
                done: false,
            }),
        }
    }

    #[test]
    fn telemetry_round_trips() {
        let t = sample();
        let bytes = encode_telemetry(&t).expect("encode");
        assert_eq!(&bytes[..4], b"MRM2");
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
        assert_eq!(parse_system_key(&system_mission("p1")), Some(SystemKey::Mission("p1".into())));
        assert_eq!(parse_system_key(SYSTEM_CMD_CREATE), Some(SystemKey::CmdCreate));
        assert_eq!(parse_team_member(&team_member("p1/ground", "r3")), Some("r3"));
        assert_eq!(parse_team_member("mrmm/team/p1/ground/member/*"), None);
        assert_eq!(team_sync("p1", 2, 7), "mrmm/team/p1/sync/2/7");
        assert_eq!(parse_mission_key(&mission_marginal("p1")), Some(("p1", "marginal")));
        assert_eq!(parse_mission_key("mrmm/missions/*/marginal"), None);
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
        let plan = r#"{"cmd":"plan","mission":"m","epoch":1,"team":"m","subteam":"m/ground","members":["r1"],
            "plan":{"robot":"r1","type":"ground","slot":0,"steps":["stream",{"sync":{"point":0}}]}}"#;
        let c: RobotCommand = from_json("cmd", plan.as_bytes()).expect("plan");
        assert!(matches!(c, RobotCommand::Plan(ref a) if a.plan.steps.len() == 2));
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

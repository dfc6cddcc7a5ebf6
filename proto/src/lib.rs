//! The mrmm protocol, which every node and tool depends on: every key expression ([`keys`]),
//! every payload type, the codecs with their size limits ([`codec`]) and the publication policy
//! ([`policy`]). No I/O: sessions are `mrmm-net`'s.
//!
//! Payloads are JSON (`application/json`) except telemetry, which is bincode behind the `MRM6`
//! prefix. Every error reply on an operator key is a Zenoh reply error whose payload is
//! [`ErrorReply`] (`{"error": "…"}`). The key space is tabled in [`keys`].
// Functions outside tests are at most 80 lines (clippy.toml); tests may be longer.
#![cfg_attr(not(test), deny(clippy::too_many_lines))]

pub mod agent;
pub mod chain;
pub mod codec;
pub mod config;
pub mod edge;
pub mod error;
pub mod geom;
pub mod ids;
pub mod journal;
pub mod keys;
pub mod map;
pub mod matching;
pub mod mission;
pub mod nav;
pub mod operator;
pub mod plan;
pub mod policy;
pub mod robot;
pub mod security;
pub mod team;
pub mod time;
pub mod traffic;

pub use agent::*;
pub use chain::ChainEnvelope;
pub use codec::{decode_telemetry, encode_telemetry, from_json, from_json_max, to_json, to_json_packed};
pub use error::{BoxError, ErrorCode, ErrorReply, ProtoError, QueryError};
pub use geom::Point;
pub use ids::{MissionName, NodeId, RobotId};
pub use journal::{ErrandRecord, JournalEntry, JournalEvent, JournalPage};
pub use keys::{
    is_hash, is_team_name, natural_cmp, team_within, validate_id, validate_subteam, validate_team_path, Key, Pattern, SystemCmd, MAX_TEAM_DEPTH,
    RESERVED_TEAM_NAMES,
};
pub use map::{MapChunk, MapInfo, MapRef};
pub use mission::*;
pub use operator::*;
pub use plan::{MissionPlan, PlanRequest, PlanSummary, RobotPlan, RobotSpec, Step, TeamSummary};
pub use robot::*;
pub use security::{Role, SecuritySection, Sender};
pub use team::*;
pub use time::Time;
pub use traffic::{TrafficOrder, TrafficReport};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_tagged_json() {
        let c: RobotCommand = from_json("cmd", br#"{"cmd":"goto","x":1,"y":2}"#).expect("goto");
        assert_eq!(c, RobotCommand::Goto { x: 1.0, y: 2.0, via: vec![], map: None });
        assert!(from_json::<RobotCommand>("cmd", br#"{"cmd":"fly"}"#).is_err());
        assert!(from_json::<GotoRequest>("goto", br#"{"robot":"r1","x":1}"#).is_err());
        let plan = r#"{"cmd":"plan","mission":"m","epoch":1,"team":"m","subteam":"m/ground","members":["r1"],
            "plan":{"robot":"r1","type":"ground","slot":0,"steps":["stream",{"sync":{"point":0}}]}}"#;
        let c: RobotCommand = from_json("cmd", plan.as_bytes()).expect("plan");
        assert!(matches!(c, RobotCommand::Plan(ref a) if a.plan.steps.len() == 2));
        let v = serde_json::to_value(RobotStatus::Lost).expect("json");
        assert_eq!(v, serde_json::json!("lost"));
    }
}

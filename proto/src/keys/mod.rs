//! Every key expression of the protocol, declared here once: a concrete key is a [`Key`], built
//! with `Display` and parsed with [`Key::parse`]; the wildcards subscribers use are [`Pattern`]s.
//! No other file of the workspace spells a key (a test greps for it).
//!
//! | key | kind | payload |
//! |---|---|---|
//! | `mrmm/robots/<id>/alive` | liveliness token of a robot | — |
//! | `mrmm/robots/<id>/info` | queryable on the robot | [`crate::RobotInfo`] |
//! | `mrmm/robots/<id>/telemetry` | publication by the robot | [`crate::Telemetry`] (bincode behind `MRM6`) |
//! | `mrmm/robots/<id>/cmd` | queryable on the robot | [`crate::RobotCommand`] → [`crate::CommandAck`] |
//! | `mrmm/team/<team path>/<type>/member/<id>` | liveliness token of a member of a leaf team | — |
//! | `mrmm/team/<team path>/sync/<point>/<round>` | publication by each member at a barrier of that team | [`crate::SyncArrival`] |
//! | `mrmm/team/<team path>/arrive/…`, `…/release/…` | the same under the leader barrier | [`crate::SyncArrival`], [`crate::SyncRelease`] |
//! | `mrmm/planner/<kind>` | queryable of a planner service | [`crate::PlanRequest`] → [`crate::MissionPlan`] |
//! | `mrmm/planner/<kind>/alive/<zid>` | liveliness token of a planner service | — |
//! | `mrmm/hosts/<node>/alive` | liveliness token of a mission host | — |
//! | `mrmm/hosts/<node>/chain` | publication to a mission host | [`crate::ChainEnvelope`] |
//! | `mrmm/hosts/<node>/start` | queryable of a mission host | [`crate::MissionStart`] → [`crate::MissionView`] |
//! | `mrmm/missions/<name>/ctl` | queryable of the mission's head | [`crate::MissionCtl`] → [`crate::CtlAck`] |
//! | `mrmm/missions/<name>/view` | queryable of the mission's head | [`crate::MissionView`] with plans |
//! | `mrmm/missions/<name>/marginal?add=±k` | queryable of the mission's head | [`crate::Marginal`] |
//! | `mrmm/missions/<name>/status` | publication of the mission's head | [`crate::MissionView`] |
//! | `mrmm/agent/advice` | queryable of the advising agent | `[`[`crate::Advice`]`]` |
//! | `mrmm/agent/advice/live` | publication of the advising agent | [`crate::AdviceEvent`] |
//! | `mrmm/system/status` | queryable on the system manager | [`crate::SystemStatus`] |
//! | `mrmm/system/robots`, `…/robots/<id>` | queryable on the system manager | [`crate::RobotView`] list / one |
//! | `mrmm/system/missions`, `…/missions/<name>` | queryable on the system manager | [`crate::MissionView`] list / one with plans |
//! | `mrmm/system/journal?since=SEQ` | queryable on the system manager | [`crate::JournalPage`] |
//! | `mrmm/system/maps` | queryable on the system manager | [`crate::MapInfo`] list |
//! | `mrmm/system/traffic` | queryable on central (its traffic authority) | [`crate::traffic::TrafficView`] list |
//! | `mrmm/maps/<hash>/<chunk>` | queryable on every node holding the map | [`crate::MapChunk`] (bincode behind `MRMP`) |
//! | `mrmm/maps/<hash>/manifest` | queryable on central, for the maps it publishes | [`crate::map::MapManifest`] (JSON, sealed by central) |
//! | `mrmm/traffic/<hash>/report/<id>` | publication by a robot on that graph map | [`crate::TrafficReport`] |
//! | `mrmm/traffic/<hash>/order/<id>` | publication by the map's traffic authority (central, or a deputy robot with central away) | [`crate::TrafficOrder`] |
//! | `mrmm/system/cmd/robot/goto` | queryable on the system manager | [`crate::GotoRequest`] |
//! | `mrmm/system/cmd/robot/move` | queryable on the system manager | [`crate::RobotMove`] |
//! | `mrmm/system/cmd/robot/capabilities` | queryable on the system manager | [`crate::CapabilitiesRequest`] |
//! | `mrmm/system/cmd/robot/crash` | queryable on the system manager | [`crate::CrashRequest`] |
//! | `mrmm/system/cmd/mission/create` | queryable on the system manager | [`crate::MissionCreate`] |
//! | `mrmm/system/cmd/mission/terminate` | queryable on the system manager | [`crate::MissionTerminate`] |
//! | `mrmm/system/cmd/mission/update` | queryable on the system manager | [`crate::MissionUpdate`] |
//! | `mrmm/system/cmd/mission/pause`, `…/resume` | queryable on the system manager | [`crate::MissionPause`] |
//!
//! Ids (robots, missions, hosts, robot types, planner kinds) are single key chunks: 1 to 64
//! characters of `[A-Za-z0-9_-]`. A team path is the mission's name followed by the names of the
//! teams down the recipe's tree (`escort/ground/north`; a recipe without teams: the mission's
//! name alone), at most [`MAX_TEAM_DEPTH`] below the mission; team names are ids other than
//! the words the keys use after a path ([`RESERVED_TEAM_NAMES`]).

use std::fmt;

use crate::error::ProtoError;
use crate::ids::{MissionName, NodeId, RobotId};

/// Whether `h` is a map hash: 64 lower-case hexadecimal digits.
pub fn is_hash(h: &str) -> bool {
    h.len() == 64 && h.bytes().all(|c| c.is_ascii_digit() || (b'a'..=b'f').contains(&c))
}

/// Checks that `id` can be a robot id, mission name, host name or robot type (one key chunk, no
/// wildcard).
pub fn validate_id(id: &str) -> Result<(), ProtoError> {
    let ok_len = !id.is_empty() && id.len() <= 64;
    let ok_chars = id.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_' || c == b'-');
    if ok_len && ok_chars {
        Ok(())
    } else {
        Err(ProtoError::BadId(id.to_string()))
    }
}

/// Orders ids as a person would: runs of digits by their value, so `r2` comes before `r10`.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let run = |s: &[u8]| s.iter().take_while(|c| c.is_ascii_digit()).count();
                let (na, nb) = (run(a), run(b));
                let (da, db) = (&a[..na], &b[..nb]);
                let strip = |d: &[u8]| d.iter().position(|c| *c != b'0').map_or(0, |p| d.len() - p);
                // The longer number (leading zeros aside) is the larger; then digit by digit;
                // then fewer leading zeros first.
                let ord = strip(da).cmp(&strip(db)).then_with(|| da[na - strip(da)..].cmp(&db[nb - strip(db)..])).then(na.cmp(&nb));
                if ord != Ordering::Equal {
                    return ord;
                }
                (a, b) = (&a[na..], &b[nb..]);
            }
            (Some(x), Some(y)) if x != y => return x.cmp(y),
            _ => (a, b) = (&a[1..], &b[1..]),
        }
    }
}

/// Teams nest at most this deep below the mission.
pub const MAX_TEAM_DEPTH: usize = 8;

/// Words that end a team path in a key, so no team below a mission may be named so.
pub const RESERVED_TEAM_NAMES: [&str; 4] = ["sync", "arrive", "release", "member"];

/// Whether `name` can name a team below a mission: an id, not one of [`RESERVED_TEAM_NAMES`].
pub fn is_team_name(name: &str) -> bool {
    validate_id(name).is_ok() && !RESERVED_TEAM_NAMES.contains(&name)
}

/// Checks a team path `<mission>[/<team>…]`: a mission name, then at most [`MAX_TEAM_DEPTH`]
/// team names.
pub fn validate_team_path(path: &str) -> Result<(), ProtoError> {
    let mut parts = path.split('/');
    let mission_ok = parts.next().is_some_and(|m| validate_id(m).is_ok());
    let teams: Vec<&str> = parts.collect();
    if mission_ok && teams.len() <= MAX_TEAM_DEPTH && teams.iter().all(|t| is_team_name(t)) {
        Ok(())
    } else {
        Err(ProtoError::BadId(path.to_string()))
    }
}

/// Whether team path `inner` is `outer` or lies below it.
pub fn team_within(inner: &str, outer: &str) -> bool {
    inner == outer || inner.strip_prefix(outer).is_some_and(|rest| rest.starts_with('/'))
}

/// Checks a sub-team path `<team path>/<type>` (the member tokens' part before `member`).
pub fn validate_subteam(subteam: &str) -> Result<(), ProtoError> {
    match subteam.rsplit_once('/') {
        Some((path, t)) if validate_team_path(path).is_ok() && validate_id(t).is_ok() => Ok(()),
        _ => Err(ProtoError::BadId(subteam.to_string())),
    }
}

/// An operator command on the system manager.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SystemCmd {
    Goto,
    Move,
    Capabilities,
    Crash,
    Create,
    Terminate,
    Update,
    Pause,
    Resume,
    /// Take a lost robot off the lanes ([`crate::traffic::TrafficClear`]).
    ClearTraffic,
    /// Send a robot to charge now ([`crate::ChargeRequest`]).
    Charge,
    /// End a robot's charging errand ([`crate::ChargeRequest`]).
    Release,
}

#[macro_use]
mod declare;
mod pattern;
#[cfg(test)]
mod tests;

use self::declare::{captures, cmd, hash, id, num, subteam, team, Part};
pub use self::pattern::Pattern;

/// A concrete key of the protocol (its chunks: `declare_keys!` below).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Key {
    RobotAlive(RobotId),
    RobotInfo(RobotId),
    RobotTelemetry(RobotId),
    RobotCmd(RobotId),
    /// `subteam` is `<team path>/<type>`.
    TeamMember {
        subteam: String,
        robot: RobotId,
    },
    TeamSync {
        team: String,
        point: u32,
        round: u32,
    },
    /// A member's arrival for the team's leader (barrier mode `leader`).
    TeamArrive {
        team: String,
        point: u32,
        round: u32,
    },
    /// The leader's release of the team's barriers up to `(round, point)` (barrier mode `leader`).
    TeamRelease {
        team: String,
        point: u32,
        round: u32,
    },
    Planner(String),
    PlannerAlive {
        kind: String,
        zid: String,
    },
    HostAlive(NodeId),
    HostChain(NodeId),
    HostStart(NodeId),
    MissionCtl(MissionName),
    MissionView(MissionName),
    MissionMarginal(MissionName),
    MissionStatus(MissionName),
    AgentAdvice,
    AgentAdviceLive,
    /// A viewer's announcement (`mrmm viz`, the demo's recording): robots that hear it tag
    /// their telemetry for it.
    Viewer(String),
    SystemStatus,
    SystemRobots,
    SystemRobot(RobotId),
    SystemMissions,
    SystemMission(MissionName),
    SystemJournal,
    SystemMaps,
    /// Traffic on every graph map, as central's authority holds it.
    SystemTraffic,
    /// Chunk `index` of the map bundle whose SHA-256 is `hash`.
    MapChunk {
        hash: String,
        index: u32,
    },
    /// The chunk hashes of the map bundle whose SHA-256 is `hash` (answered by central).
    MapManifest {
        hash: String,
    },
    /// Robot `robot`'s report to the traffic authority of the map whose bundle hash is `map`.
    TrafficReport {
        map: String,
        robot: RobotId,
    },
    /// The traffic authority's order to robot `robot` on map `map`.
    TrafficOrder {
        map: String,
        robot: RobotId,
    },
    SystemCmd(SystemCmd),
}

// Every concrete key, declared once: its variant and its chunks. Both `Display` and
// [`Key::parse`] are generated from this table (`declare_keys!`, below), so a key cannot be
// built one way and parsed another. A chunk is a literal, or a field of the variant: `id` (one
// id chunk), `num` (one decimal chunk), `hash` (a map bundle's SHA-256), `team` (a team path:
// one chunk or more), `subteam` (a team path and a robot type), `cmd` (an operator command's
// chunks). Parsing tries the keys in this order.
declare_keys! {
    RobotAlive(id) => "mrmm" / "robots" / {id: id} / "alive";
    RobotInfo(id) => "mrmm" / "robots" / {id: id} / "info";
    RobotTelemetry(id) => "mrmm" / "robots" / {id: id} / "telemetry";
    RobotCmd(id) => "mrmm" / "robots" / {id: id} / "cmd";
    TeamMember { subteam, robot } => "mrmm" / "team" / {subteam: subteam} / "member" / {robot: id};
    TeamSync { team, point, round } => "mrmm" / "team" / {team: team} / "sync" / {point: num} / {round: num};
    TeamArrive { team, point, round } => "mrmm" / "team" / {team: team} / "arrive" / {point: num} / {round: num};
    TeamRelease { team, point, round } => "mrmm" / "team" / {team: team} / "release" / {point: num} / {round: num};
    Planner(kind) => "mrmm" / "planner" / {kind: id};
    PlannerAlive { kind, zid } => "mrmm" / "planner" / {kind: id} / "alive" / {zid: id};
    HostAlive(node) => "mrmm" / "hosts" / {node: id} / "alive";
    HostChain(node) => "mrmm" / "hosts" / {node: id} / "chain";
    HostStart(node) => "mrmm" / "hosts" / {node: id} / "start";
    MissionCtl(name) => "mrmm" / "missions" / {name: id} / "ctl";
    MissionView(name) => "mrmm" / "missions" / {name: id} / "view";
    MissionMarginal(name) => "mrmm" / "missions" / {name: id} / "marginal";
    MissionStatus(name) => "mrmm" / "missions" / {name: id} / "status";
    AgentAdvice => "mrmm" / "agent" / "advice";
    AgentAdviceLive => "mrmm" / "agent" / "advice" / "live";
    Viewer(id) => "mrmm" / "viewers" / {id: id};
    SystemStatus => "mrmm" / "system" / "status";
    SystemRobots => "mrmm" / "system" / "robots";
    SystemRobot(id) => "mrmm" / "system" / "robots" / {id: id};
    SystemMissions => "mrmm" / "system" / "missions";
    SystemMission(name) => "mrmm" / "system" / "missions" / {name: id};
    SystemJournal => "mrmm" / "system" / "journal";
    SystemMaps => "mrmm" / "system" / "maps";
    SystemTraffic => "mrmm" / "system" / "traffic";
    MapChunk { hash, index } => "mrmm" / "maps" / {hash: hash} / {index: num};
    MapManifest { hash } => "mrmm" / "maps" / {hash: hash} / "manifest";
    TrafficReport { map, robot } => "mrmm" / "traffic" / {map: hash} / "report" / {robot: id};
    TrafficOrder { map, robot } => "mrmm" / "traffic" / {map: hash} / "order" / {robot: id};
    SystemCmd(cmd) => "mrmm" / "system" / "cmd" / {cmd: cmd};
}

impl SystemCmd {
    /// Every operator command with its chunks after `mrmm/system/cmd/`: declared once, for
    /// building and parsing alike.
    const ALL: [(SystemCmd, &'static str); 12] = [
        (SystemCmd::Goto, "robot/goto"),
        (SystemCmd::Move, "robot/move"),
        (SystemCmd::Capabilities, "robot/capabilities"),
        (SystemCmd::Crash, "robot/crash"),
        (SystemCmd::Create, "mission/create"),
        (SystemCmd::Terminate, "mission/terminate"),
        (SystemCmd::Update, "mission/update"),
        (SystemCmd::Pause, "mission/pause"),
        (SystemCmd::Resume, "mission/resume"),
        (SystemCmd::ClearTraffic, "traffic/clear"),
        (SystemCmd::Charge, "robot/charge"),
        (SystemCmd::Release, "robot/release"),
    ];

    fn chunks(self) -> &'static str {
        Self::ALL.iter().find(|(c, _)| *c == self).map_or("", |(_, s)| s)
    }

    fn parse(chunks: &[&str]) -> Option<SystemCmd> {
        let path = chunks.join("/");
        Self::ALL.iter().find(|(_, s)| *s == path).map(|(c, _)| *c)
    }
}

impl fmt::Display for SystemCmd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.chunks())
    }
}

impl Key {
    /// The team-member token of `robot` in `subteam` (`<team path>/<type>`), checked.
    pub fn team_member(subteam: &str, robot: &str) -> Result<Key, ProtoError> {
        validate_subteam(subteam)?;
        validate_id(robot)?;
        Ok(Key::TeamMember { subteam: subteam.to_string(), robot: robot.into() })
    }
}

/// The selector of a marginal-benefit query: `mrmm/missions/<name>/marginal?add=<add>`.
pub fn marginal_selector(mission: &str, add: i64) -> String {
    format!("{}?add={add}", Key::MissionMarginal(mission.into()))
}

/// What the experiments count on the wire, by kind: (kind, key expression). Zenoh counts the
/// messages each node sends and receives on these (`mrmm_net::net::enable_wire_stats`).
pub const WIRE_KINDS: [(&str, &str); 8] = [
    ("sync", "mrmm/team/**/sync/*/*"),
    ("arrive", "mrmm/team/**/arrive/*/*"),
    ("release", "mrmm/team/**/release/*/*"),
    ("telemetry", "mrmm/robots/*/telemetry"),
    // Plans, orders and admissions (queries) and their answers.
    ("command", "mrmm/robots/*/cmd"),
    ("chain", "mrmm/hosts/*/chain"),
    ("mission", "mrmm/missions/**"),
    ("system", "mrmm/system/**"),
];

/// The selector of every node's admin-space record with its wire statistics (peers and
/// routers): `@/*/<whatami>?_stats=true`.
pub fn wire_stats_selector(whatami: &str) -> String {
    format!("@/*/{whatami}?_stats=true")
}

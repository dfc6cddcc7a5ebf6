//! Every key expression of the protocol, declared here once: a concrete key is a [`Key`], built
//! with `Display` and parsed with [`Key::parse`]; the wildcards subscribers use are [`Pattern`]s.
//! No other file of the workspace spells a key (a test greps for it).
//!
//! | key | kind | payload |
//! |---|---|---|
//! | `mrmm/robots/<id>/alive` | liveliness token of a robot | — |
//! | `mrmm/robots/<id>/info` | queryable on the robot | [`crate::RobotInfo`] |
//! | `mrmm/robots/<id>/telemetry` | publication by the robot | [`crate::Telemetry`] (bincode behind `MRM3`) |
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
//! | `mrmm/maps/<hash>/<chunk>` | queryable on every node holding the map | [`crate::MapChunk`] (bincode behind `MRMP`) |
//! | `mrmm/system/cmd/robot/goto` | queryable on the system manager | [`crate::GotoRequest`] |
//! | `mrmm/system/cmd/robot/move` | queryable on the system manager | [`crate::RobotMove`] |
//! | `mrmm/system/cmd/robot/capabilities` | queryable on the system manager | [`crate::CapabilitiesRequest`] |
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

/// A team path from key chunks, checked.
fn team_path(chunks: &[&str]) -> Option<String> {
    let path = chunks.join("/");
    validate_team_path(&path).ok().map(|_| path)
}

/// An operator command on the system manager.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SystemCmd {
    Goto,
    Move,
    Capabilities,
    Create,
    Terminate,
    Update,
    Pause,
    Resume,
}

/// A concrete key of the protocol.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Key {
    RobotAlive(String),
    RobotInfo(String),
    RobotTelemetry(String),
    RobotCmd(String),
    /// `subteam` is `<team path>/<type>`.
    TeamMember {
        subteam: String,
        robot: String,
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
    HostAlive(String),
    HostChain(String),
    HostStart(String),
    MissionCtl(String),
    MissionView(String),
    MissionMarginal(String),
    MissionStatus(String),
    AgentAdvice,
    AgentAdviceLive,
    /// A viewer's announcement (`mrmm viz`, the demo's recording): robots that hear it tag
    /// their telemetry for it.
    Viewer(String),
    SystemStatus,
    SystemRobots,
    SystemRobot(String),
    SystemMissions,
    SystemMission(String),
    SystemJournal,
    SystemMaps,
    /// Chunk `index` of the map bundle whose SHA-256 is `hash`.
    MapChunk {
        hash: String,
        index: u32,
    },
    SystemCmd(SystemCmd),
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Key::RobotAlive(id) => write!(f, "mrmm/robots/{id}/alive"),
            Key::RobotInfo(id) => write!(f, "mrmm/robots/{id}/info"),
            Key::RobotTelemetry(id) => write!(f, "mrmm/robots/{id}/telemetry"),
            Key::RobotCmd(id) => write!(f, "mrmm/robots/{id}/cmd"),
            Key::TeamMember { subteam, robot } => write!(f, "mrmm/team/{subteam}/member/{robot}"),
            Key::TeamSync { team, point, round } => write!(f, "mrmm/team/{team}/sync/{point}/{round}"),
            Key::TeamArrive { team, point, round } => write!(f, "mrmm/team/{team}/arrive/{point}/{round}"),
            Key::TeamRelease { team, point, round } => write!(f, "mrmm/team/{team}/release/{point}/{round}"),
            Key::Planner(kind) => write!(f, "mrmm/planner/{kind}"),
            Key::PlannerAlive { kind, zid } => write!(f, "mrmm/planner/{kind}/alive/{zid}"),
            Key::HostAlive(n) => write!(f, "mrmm/hosts/{n}/alive"),
            Key::HostChain(n) => write!(f, "mrmm/hosts/{n}/chain"),
            Key::HostStart(n) => write!(f, "mrmm/hosts/{n}/start"),
            Key::MissionCtl(m) => write!(f, "mrmm/missions/{m}/ctl"),
            Key::MissionView(m) => write!(f, "mrmm/missions/{m}/view"),
            Key::MissionMarginal(m) => write!(f, "mrmm/missions/{m}/marginal"),
            Key::MissionStatus(m) => write!(f, "mrmm/missions/{m}/status"),
            Key::AgentAdvice => f.write_str("mrmm/agent/advice"),
            Key::AgentAdviceLive => f.write_str("mrmm/agent/advice/live"),
            Key::Viewer(v) => write!(f, "mrmm/viewers/{v}"),
            Key::SystemStatus => f.write_str("mrmm/system/status"),
            Key::SystemRobots => f.write_str("mrmm/system/robots"),
            Key::SystemRobot(id) => write!(f, "mrmm/system/robots/{id}"),
            Key::SystemMissions => f.write_str("mrmm/system/missions"),
            Key::SystemMission(m) => write!(f, "mrmm/system/missions/{m}"),
            Key::SystemJournal => f.write_str("mrmm/system/journal"),
            Key::SystemMaps => f.write_str("mrmm/system/maps"),
            Key::MapChunk { hash, index } => write!(f, "mrmm/maps/{hash}/{index}"),
            Key::SystemCmd(SystemCmd::Goto) => f.write_str("mrmm/system/cmd/robot/goto"),
            Key::SystemCmd(SystemCmd::Move) => f.write_str("mrmm/system/cmd/robot/move"),
            Key::SystemCmd(SystemCmd::Capabilities) => f.write_str("mrmm/system/cmd/robot/capabilities"),
            Key::SystemCmd(SystemCmd::Create) => f.write_str("mrmm/system/cmd/mission/create"),
            Key::SystemCmd(SystemCmd::Terminate) => f.write_str("mrmm/system/cmd/mission/terminate"),
            Key::SystemCmd(SystemCmd::Update) => f.write_str("mrmm/system/cmd/mission/update"),
            Key::SystemCmd(SystemCmd::Pause) => f.write_str("mrmm/system/cmd/mission/pause"),
            Key::SystemCmd(SystemCmd::Resume) => f.write_str("mrmm/system/cmd/mission/resume"),
        }
    }
}

/// One id chunk, checked.
fn id(s: &str) -> Option<String> {
    validate_id(s).ok().map(|_| s.to_string())
}

/// A decimal chunk without sign or leading `+`.
fn num(s: &str) -> Option<u32> {
    (!s.is_empty() && s.bytes().all(|b| b.is_ascii_digit())).then(|| s.parse().ok()).flatten()
}

impl Key {
    /// Parses a concrete key; `None` for anything that is not exactly one of ours (wildcards,
    /// extra chunks, bad ids).
    pub fn parse(key: &str) -> Option<Key> {
        let parts: Vec<&str> = key.split('/').collect();
        let k = match parts.as_slice() {
            ["mrmm", "robots", r, "alive"] => Key::RobotAlive(id(r)?),
            ["mrmm", "robots", r, "info"] => Key::RobotInfo(id(r)?),
            ["mrmm", "robots", r, "telemetry"] => Key::RobotTelemetry(id(r)?),
            ["mrmm", "robots", r, "cmd"] => Key::RobotCmd(id(r)?),
            ["mrmm", "team", sub @ .., "member", r] => {
                let subteam = sub.join("/");
                validate_subteam(&subteam).ok()?;
                Key::TeamMember { subteam, robot: id(r)? }
            }
            ["mrmm", "team", t @ .., "sync", p, r] => Key::TeamSync { team: team_path(t)?, point: num(p)?, round: num(r)? },
            ["mrmm", "team", t @ .., "arrive", p, r] => Key::TeamArrive { team: team_path(t)?, point: num(p)?, round: num(r)? },
            ["mrmm", "team", t @ .., "release", p, r] => Key::TeamRelease { team: team_path(t)?, point: num(p)?, round: num(r)? },
            ["mrmm", "planner", k] => Key::Planner(id(k)?),
            ["mrmm", "planner", k, "alive", z] => Key::PlannerAlive { kind: id(k)?, zid: id(z)? },
            ["mrmm", "hosts", n, "alive"] => Key::HostAlive(id(n)?),
            ["mrmm", "hosts", n, "chain"] => Key::HostChain(id(n)?),
            ["mrmm", "hosts", n, "start"] => Key::HostStart(id(n)?),
            ["mrmm", "missions", m, "ctl"] => Key::MissionCtl(id(m)?),
            ["mrmm", "missions", m, "view"] => Key::MissionView(id(m)?),
            ["mrmm", "missions", m, "marginal"] => Key::MissionMarginal(id(m)?),
            ["mrmm", "missions", m, "status"] => Key::MissionStatus(id(m)?),
            ["mrmm", "agent", "advice"] => Key::AgentAdvice,
            ["mrmm", "agent", "advice", "live"] => Key::AgentAdviceLive,
            ["mrmm", "viewers", v] => Key::Viewer(id(v)?),
            ["mrmm", "system", "status"] => Key::SystemStatus,
            ["mrmm", "system", "robots"] => Key::SystemRobots,
            ["mrmm", "system", "robots", r] => Key::SystemRobot(id(r)?),
            ["mrmm", "system", "missions"] => Key::SystemMissions,
            ["mrmm", "system", "missions", m] => Key::SystemMission(id(m)?),
            ["mrmm", "system", "journal"] => Key::SystemJournal,
            ["mrmm", "system", "maps"] => Key::SystemMaps,
            ["mrmm", "maps", h, i] if crate::map::is_hash(h) => Key::MapChunk { hash: h.to_string(), index: num(i)? },
            ["mrmm", "system", "cmd", "robot", "goto"] => Key::SystemCmd(SystemCmd::Goto),
            ["mrmm", "system", "cmd", "robot", "move"] => Key::SystemCmd(SystemCmd::Move),
            ["mrmm", "system", "cmd", "robot", "capabilities"] => Key::SystemCmd(SystemCmd::Capabilities),
            ["mrmm", "system", "cmd", "mission", "create"] => Key::SystemCmd(SystemCmd::Create),
            ["mrmm", "system", "cmd", "mission", "terminate"] => Key::SystemCmd(SystemCmd::Terminate),
            ["mrmm", "system", "cmd", "mission", "update"] => Key::SystemCmd(SystemCmd::Update),
            ["mrmm", "system", "cmd", "mission", "pause"] => Key::SystemCmd(SystemCmd::Pause),
            ["mrmm", "system", "cmd", "mission", "resume"] => Key::SystemCmd(SystemCmd::Resume),
            _ => return None,
        };
        Some(k)
    }

    /// The team-member token of `robot` in `subteam` (`<team path>/<type>`), checked.
    pub fn team_member(subteam: &str, robot: &str) -> Result<Key, ProtoError> {
        validate_subteam(subteam)?;
        validate_id(robot)?;
        Ok(Key::TeamMember { subteam: subteam.to_string(), robot: robot.to_string() })
    }
}

/// The selector of a marginal-benefit query: `mrmm/missions/<name>/marginal?add=<add>`.
pub fn marginal_selector(mission: &str, add: i64) -> String {
    format!("{}?add={add}", Key::MissionMarginal(mission.to_string()))
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

/// A wildcard key expression a node subscribes or listens to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Pattern {
    /// `mrmm/robots/*/alive`
    AllRobotsAlive,
    /// `mrmm/robots/*/telemetry`
    AllTelemetry,
    /// `mrmm/hosts/*/alive`
    AllHostsAlive,
    /// `mrmm/planner/*/alive/*`
    AllPlannersAlive,
    /// `mrmm/missions/*/status`
    AllMissionStatus,
    /// `mrmm/viewers/*`
    AllViewers,
    /// Every member token of a team and the teams below it: `mrmm/team/<team path>/**/member/*`
    TeamMembers(String),
    /// Every barrier of one team (not of the teams below it): `mrmm/team/<team path>/sync/*/*`
    TeamSync(String),
    /// Every barrier of every team: `mrmm/team/**/sync/*/*`
    AllTeamSync,
    /// Every arrival for a team's leader: `mrmm/team/<team path>/arrive/*/*`
    TeamArrive(String),
    /// Every release of a team's leader: `mrmm/team/<team path>/release/*/*`
    TeamRelease(String),
    /// Every release of every team: `mrmm/team/**/release/*/*`
    AllTeamRelease,
    /// Everything the system manager answers: `mrmm/system/**`
    SystemAll,
    /// Every operator command: `mrmm/system/cmd/**`
    SystemCmdAll,
    /// Everything the advising agent answers and publishes: `mrmm/agent/**`
    AgentAll,
    /// Every chunk of every map: `mrmm/maps/*/*`
    AllMapChunks,
    /// Everything of mrmm: `mrmm/**`
    All,
}

impl fmt::Display for Pattern {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pattern::AllRobotsAlive => f.write_str("mrmm/robots/*/alive"),
            Pattern::AllTelemetry => f.write_str("mrmm/robots/*/telemetry"),
            Pattern::AllHostsAlive => f.write_str("mrmm/hosts/*/alive"),
            Pattern::AllPlannersAlive => f.write_str("mrmm/planner/*/alive/*"),
            Pattern::AllMissionStatus => f.write_str("mrmm/missions/*/status"),
            Pattern::AllViewers => f.write_str("mrmm/viewers/*"),
            Pattern::TeamMembers(team) => write!(f, "mrmm/team/{team}/**/member/*"),
            Pattern::TeamSync(team) => write!(f, "mrmm/team/{team}/sync/*/*"),
            Pattern::AllTeamSync => f.write_str("mrmm/team/**/sync/*/*"),
            Pattern::TeamArrive(team) => write!(f, "mrmm/team/{team}/arrive/*/*"),
            Pattern::TeamRelease(team) => write!(f, "mrmm/team/{team}/release/*/*"),
            Pattern::AllTeamRelease => f.write_str("mrmm/team/**/release/*/*"),
            Pattern::SystemAll => f.write_str("mrmm/system/**"),
            Pattern::SystemCmdAll => f.write_str("mrmm/system/cmd/**"),
            Pattern::AgentAll => f.write_str("mrmm/agent/**"),
            Pattern::AllMapChunks => f.write_str("mrmm/maps/*/*"),
            Pattern::All => f.write_str("mrmm/**"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    // Zenoh's own key expressions (a dev-dependency): every key is one, every pattern matches its keys.
    use zenoh::key_expr::KeyExpr;

    #[test]
    fn ids_sort_naturally() {
        let mut ids = vec!["r10", "r2", "r1", "r100", "a", "r02", "r9b", "r9a", "x-3", "x-20", "r"];
        ids.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(ids, vec!["a", "r", "r1", "r2", "r02", "r9a", "r9b", "r10", "r100", "x-3", "x-20"]);
    }

    proptest! {
        #[test]
        fn natural_order_is_total(a in "[a-c0-9]{0,6}", b in "[a-c0-9]{0,6}") {
            prop_assert_eq!(natural_cmp(&a, &b), natural_cmp(&b, &a).reverse());
            prop_assert_eq!(natural_cmp(&a, &b) == std::cmp::Ordering::Equal, a == b);
        }
    }

    fn all_keys() -> Vec<Key> {
        let s = |v: &str| v.to_string();
        vec![
            Key::RobotAlive(s("r1")),
            Key::RobotInfo(s("r-2")),
            Key::RobotTelemetry(s("a_b")),
            Key::RobotCmd(s("r1")),
            Key::TeamMember { subteam: s("p1/ground"), robot: s("r3") },
            Key::TeamMember { subteam: s("p1/sync"), robot: s("r3") },
            Key::TeamSync { team: s("p1"), point: 2, round: 7 },
            Key::TeamArrive { team: s("p1"), point: 2, round: 7 },
            Key::TeamRelease { team: s("p1"), point: 0, round: 3 },
            Key::TeamMember { subteam: s("p1/ground/north/drone"), robot: s("r3") },
            Key::TeamSync { team: s("p1/ground/north"), point: 2, round: 7 },
            Key::TeamSync { team: s("sync"), point: 2, round: 7 },
            Key::TeamArrive { team: s("p1/air"), point: 2, round: 7 },
            Key::TeamRelease { team: s("p1/air/a-1"), point: 0, round: 3 },
            Key::Planner(s("patrol")),
            Key::PlannerAlive { kind: s("coverage"), zid: s("0a1b") },
            Key::HostAlive(s("central")),
            Key::HostChain(s("r1")),
            Key::HostStart(s("h2")),
            Key::MissionCtl(s("m")),
            Key::MissionView(s("m")),
            Key::MissionMarginal(s("m")),
            Key::MissionStatus(s("m")),
            Key::AgentAdvice,
            Key::AgentAdviceLive,
            Key::Viewer(s("op")),
            Key::SystemStatus,
            Key::SystemRobots,
            Key::SystemRobot(s("r9")),
            Key::SystemMissions,
            Key::SystemMission(s("p1")),
            Key::SystemJournal,
            Key::SystemMaps,
            Key::MapChunk { hash: "0f".repeat(32), index: 3 },
            Key::SystemCmd(SystemCmd::Goto),
            Key::SystemCmd(SystemCmd::Move),
            Key::SystemCmd(SystemCmd::Capabilities),
            Key::SystemCmd(SystemCmd::Create),
            Key::SystemCmd(SystemCmd::Terminate),
            Key::SystemCmd(SystemCmd::Update),
            Key::SystemCmd(SystemCmd::Pause),
            Key::SystemCmd(SystemCmd::Resume),
        ]
    }

    #[test]
    fn every_key_round_trips_and_is_a_valid_key_expression() {
        for k in all_keys() {
            let text = k.to_string();
            assert_eq!(Key::parse(&text), Some(k.clone()), "{text}");
            assert!(KeyExpr::try_from(text.as_str()).is_ok(), "{text}");
        }
        assert_eq!(Key::RobotAlive("r1".into()).to_string(), "mrmm/robots/r1/alive");
        assert_eq!(Key::TeamSync { team: "p1".into(), point: 2, round: 7 }.to_string(), "mrmm/team/p1/sync/2/7");
    }

    #[test]
    fn patterns_match_the_keys_they_are_for() {
        let matches = |p: Pattern, k: Key| {
            let p = KeyExpr::try_from(p.to_string()).expect("pattern");
            let k = KeyExpr::try_from(k.to_string()).expect("key");
            p.intersects(&k)
        };
        let s = |v: &str| v.to_string();
        assert!(matches(Pattern::AllRobotsAlive, Key::RobotAlive(s("r1"))));
        assert!(!matches(Pattern::AllRobotsAlive, Key::RobotInfo(s("r1"))));
        assert!(matches(Pattern::AllTelemetry, Key::RobotTelemetry(s("r1"))));
        assert!(matches(Pattern::AllHostsAlive, Key::HostAlive(s("r1"))));
        assert!(matches(Pattern::AllPlannersAlive, Key::PlannerAlive { kind: s("patrol"), zid: s("ab") }));
        assert!(matches(Pattern::AllMissionStatus, Key::MissionStatus(s("p"))));
        assert!(matches(Pattern::AllViewers, Key::Viewer(s("op"))));
        assert!(matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("p/ground"), robot: s("r1") }));
        assert!(!matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("q/ground"), robot: s("r1") }));
        assert!(matches(Pattern::TeamSync(s("p")), Key::TeamSync { team: s("p"), point: 0, round: 0 }));
        assert!(matches(Pattern::AllTeamSync, Key::TeamSync { team: s("q"), point: 1, round: 3 }));
        assert!(matches(Pattern::TeamArrive(s("p")), Key::TeamArrive { team: s("p"), point: 1, round: 3 }));
        assert!(!matches(Pattern::TeamArrive(s("p")), Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
        assert!(matches(Pattern::TeamRelease(s("p")), Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
        assert!(!matches(Pattern::TeamMembers(s("p")), Key::TeamArrive { team: s("p"), point: 1, round: 3 }));
        // A team's patterns take in the teams below it for membership, never a sibling's, and
        // only its own barriers.
        assert!(matches(Pattern::TeamMembers(s("p")), Key::TeamMember { subteam: s("p/air/north/drone"), robot: s("r1") }));
        assert!(matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/air/north/drone"), robot: s("r1") }));
        assert!(!matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/ground/drone"), robot: s("r1") }));
        assert!(!matches(Pattern::TeamMembers(s("p/air")), Key::TeamMember { subteam: s("p/air2/drone"), robot: s("r1") }));
        assert!(!matches(Pattern::TeamSync(s("p")), Key::TeamSync { team: s("p/air"), point: 0, round: 0 }));
        assert!(!matches(Pattern::TeamSync(s("p/air")), Key::TeamSync { team: s("p"), point: 0, round: 0 }));
        assert!(!matches(Pattern::TeamSync(s("p/air")), Key::TeamSync { team: s("p/ground"), point: 0, round: 0 }));
        assert!(matches(Pattern::AllTeamSync, Key::TeamSync { team: s("p/air/x"), point: 1, round: 3 }));
        assert!(matches(Pattern::AllTeamRelease, Key::TeamRelease { team: s("p/air/x"), point: 1, round: 3 }));
        assert!(matches(Pattern::AllTeamRelease, Key::TeamRelease { team: s("p"), point: 1, round: 3 }));
        assert!(matches(Pattern::SystemAll, Key::SystemCmd(SystemCmd::Create)));
        assert!(!matches(Pattern::SystemAll, Key::AgentAdvice));
    }

    #[test]
    fn foreign_keys_are_refused() {
        for bad in [
            "mrmm/robots/r1/alive/x",
            "other/robots/r1/alive",
            "mrmm/robots/*/alive",
            "mrmm/system/robots/a/b",
            "mrmm/system/nope",
            "mrmm/team/p1/ground/member/*",
            "mrmm/team/p1/sync/-1/2",
            "mrmm/team/p1/sync/+1/2",
            "mrmm/team/p1/sync/99999999999/2",
            "mrmm/team/sync/3",
            "mrmm/team/p1/member/sync/1/2",
            "mrmm/team/p1/a/b/c/d/e/f/g/h/i/sync/1/2",
            "mrmm/team/member/r1",
            "mrmm/missions/*/marginal",
            "",
        ] {
            assert_eq!(Key::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn ids_are_single_chunks() {
        assert!(validate_id("robot-01_a").is_ok());
        for bad in ["", "a/b", "*", "a b", "é", &"x".repeat(65)] {
            assert!(validate_id(bad).is_err(), "{bad:?}");
        }
        assert!(validate_subteam("m/ground").is_ok());
        assert!(validate_subteam("m/g/x").is_ok());
        for bad in ["m", "m/", "/g", "m/sync/x", "m/*", "m//g"] {
            assert!(validate_subteam(bad).is_err(), "{bad:?}");
        }
        assert!(validate_team_path("m/a/b").is_ok());
        assert!(validate_team_path(&format!("m{}", "/t".repeat(MAX_TEAM_DEPTH))).is_ok());
        assert!(validate_team_path(&format!("m{}", "/t".repeat(MAX_TEAM_DEPTH + 1))).is_err());
        assert!(team_within("m/a/b", "m/a") && team_within("m/a", "m/a") && team_within("m/a", "m"));
        assert!(!team_within("m/ab", "m/a") && !team_within("m", "m/a"));
        assert_eq!(marginal_selector("p", -2), "mrmm/missions/p/marginal?add=-2");
    }

    proptest! {
        #[test]
        fn parse_never_panics(s in "\\PC{0,60}") {
            let _ = Key::parse(&s);
        }
    }
}

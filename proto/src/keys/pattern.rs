//! The wildcard key expressions nodes subscribe and listen to.

use std::fmt;

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
    /// Every chunk of one map, and its manifest: `mrmm/maps/<hash>/*`
    MapChunks(String),
    /// Every robot's report to every traffic authority: `mrmm/traffic/*/report/*`
    AllTrafficReports,
    /// Every traffic authority's orders to one robot: `mrmm/traffic/*/order/<id>`
    TrafficOrders(String),
    /// Every order of every traffic authority (to watch traffic): `mrmm/traffic/*/order/*`
    AllTrafficOrders,
    /// Every report and every order on one map (its traffic deputies follow them):
    /// `mrmm/traffic/<hash>/*/*`
    MapTraffic(String),
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
            Pattern::MapChunks(hash) => write!(f, "mrmm/maps/{hash}/*"),
            Pattern::AllTrafficReports => f.write_str("mrmm/traffic/*/report/*"),
            Pattern::TrafficOrders(id) => write!(f, "mrmm/traffic/*/order/{id}"),
            Pattern::AllTrafficOrders => f.write_str("mrmm/traffic/*/order/*"),
            Pattern::MapTraffic(hash) => write!(f, "mrmm/traffic/{hash}/*/*"),
            Pattern::All => f.write_str("mrmm/**"),
        }
    }
}

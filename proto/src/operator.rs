//! Operator-facing payloads: requests and answers of the system manager's keys (JSON).

use std::collections::BTreeMap;

use crate::plan::{PlanSummary, RobotPlan};
use serde::{Deserialize, Serialize};

use crate::ids::{MissionName, NodeId, RobotId};
use crate::robot::Pose;

/// How often a viewer announces itself on `Key::Viewer` (robots tag their telemetry for the
/// viewers they heard within three such periods).
pub const VIEWER_HELLO_MS: u64 = 2000;

/// Operator command `mrmm/system/cmd/robot/goto`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GotoRequest {
    pub robot: RobotId,
    pub x: f64,
    pub y: f64,
    /// Drive there along this map of central's (`mrmm op maps`); none named: central's map if it
    /// holds exactly one, else a straight line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
}

/// Operator command `mrmm/system/cmd/robot/crash`: crash a simulated robot (a test of what the
/// fleet does when it loses one; robots with a ROS 2 body refuse).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CrashRequest {
    pub robot: RobotId,
}

/// `mrmm/system/cmd/robot/charge` (send the robot to charge now, whatever its charge) and
/// `mrmm/system/cmd/robot/release` (end its charging errand: unplugged, back to its mission if
/// that mission is short of it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChargeRequest {
    pub robot: RobotId,
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
    pub id: RobotId,
    #[serde(rename = "type")]
    pub robot_type: String,
    pub capabilities: Vec<String>,
    pub status: RobotStatus,
    /// The mission the system manager assigned the robot to.
    pub mission: Option<MissionName>,
    pub pose: Option<Pose>,
    /// What the robot reported doing last (`hold`, `goto(x,y)`, `plan step 4`).
    #[serde(default)]
    pub behaviour: Option<String>,
    /// Where the robot drives to now (the goal of its behaviour), while it drives.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<crate::geom::Point>,
    /// For a lost robot: the mission it was taken out of.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_mission: Option<MissionName>,
    /// Why the robot cannot get to its goal, as it reports it (a real body's navigator refused
    /// or aborted the goal, or is not running).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stuck: Option<String>,
    /// The robot's battery as it last reported it, if it has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub battery: Option<crate::robot::BatteryState>,
    /// A VDA 5050 vehicle's own word on itself, as its robot last reported it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::robot::VehicleState>,
}

/// Fleet summary (`mrmm/system/status`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SystemStatus {
    /// Zenoh id of the system manager's session.
    pub node: NodeId,
    pub uptime_s: f64,
    pub robots_total: usize,
    pub idle: usize,
    pub busy: usize,
    pub lost: usize,
    #[serde(default)]
    pub missions: usize,
    /// Messages central refused, by reason (`signature`, `not_entitled`, …): strangers' and
    /// impostors' attempts.
    #[serde(default)]
    pub refused: std::collections::BTreeMap<String, u64>,
    /// Messages central took, by how their sender was proven: `tag` (a pair key's HMAC) or
    /// `signature` (Ed25519); empty in an insecure fleet.
    #[serde(default)]
    pub proven: std::collections::BTreeMap<String, u64>,
}

/// `mrmm/system/cmd/mission/create`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct MissionCreate {
    pub name: MissionName,
    /// A recipe of the bank (`patrol`, `coverage`) or a whole recipe XML document.
    pub recipe: String,
    /// Exactly these robots.
    #[serde(default)]
    pub robots: Option<Vec<RobotId>>,
    /// Or this many idle robots.
    #[serde(default)]
    pub count: Option<usize>,
    /// Recipe parameter overrides: scalars, `waypoints` `[[x, y], …]`, `region`.
    #[serde(default)]
    pub params: BTreeMap<String, serde_json::Value>,
    /// The mission host to run the manager on (default: `central`).
    #[serde(default)]
    pub host: Option<NodeId>,
    /// Robots replicating the mission manager's state (default 2, at most 8).
    #[serde(default)]
    pub replicas: Option<usize>,
    /// A map central holds (`mrmm op maps`): the mission plans on it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
}

/// `mrmm/system/cmd/mission/terminate`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionTerminate {
    pub name: MissionName,
}

/// `mrmm/system/cmd/mission/update`: new parameters (merged into the mission's: `waypoints`,
/// `region`, `rounds`, `sync_spacing_max`, `barrier`, `max_worst_idleness`, …) and/or another map
/// of central's. Checked in full (a dry-run plan) before anything changes; the mission's manager
/// replans its members as its next epoch. A mission of teams takes parameters per leaf team too:
/// `"teams": {"ground": {"rounds": 2}}` (the same as `"params": {"ground/rounds": 2}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct MissionUpdate {
    pub name: MissionName,
    #[serde(default)]
    pub params: BTreeMap<String, serde_json::Value>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<String>,
    /// Parameters of one leaf team, by its path below the mission.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub teams: BTreeMap<String, BTreeMap<String, serde_json::Value>>,
}

/// `mrmm/system/cmd/mission/pause` and `…/resume`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionPause {
    pub name: MissionName,
}

/// `mrmm/system/cmd/robot/move`: `to` a mission, or `null` to free the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotMove {
    pub robot: RobotId,
    pub to: Option<MissionName>,
    /// A member of mission `to` whose place the robot takes (a hand-over): the member leaves
    /// and the robot carries on its plan from where it was, the other members going on with
    /// theirs (no replan). The leaver is freed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replaces: Option<RobotId>,
}

/// `mrmm/system/cmd/robot/capabilities`: the robot's capabilities change (names to add and to
/// remove); it leaves a mission whose recipe requires one it no longer has.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CapabilitiesRequest {
    pub robot: RobotId,
    #[serde(default)]
    pub add: Vec<String>,
    #[serde(default)]
    pub remove: Vec<String>,
}

/// Lifecycle of a mission.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissionStatus {
    /// Waiting for plans.
    Planning,
    Running,
    /// No robot left.
    Stalled,
    /// Planning failed; the reason is in `error`.
    Failed,
    /// Paused by the operator: every member holds where it is, no barrier, no idleness clock.
    Paused,
}

/// Mission metrics computed from telemetry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct MissionMetrics {
    /// Rounds completed by every member (patrol).
    pub rounds: u32,
    /// Mean time between two visits of a waypoint, robot seconds (wall seconds × the robots'
    /// time scale; 1 for real robots) like the planner's predictions (patrol).
    pub avg_idleness: Option<f64>,
    /// Longest time a waypoint went unvisited, robot seconds (patrol).
    pub worst_idleness: Option<f64>,
    /// Visits per waypoint, in tour order (patrol).
    pub visits: Vec<u32>,
    /// Barriers passed by the whole team.
    pub sync_points_passed: u32,
    /// Coordination messages sent, per kind (`plan`, `leave`, `sync`).
    pub messages: BTreeMap<String, u64>,
    /// Robot seconds the members spent waiting at barriers under the current plan, after its
    /// first barrier (the formation's), summed over members (it restarts with a replan).
    #[serde(default)]
    pub sync_wait_s: f64,
    /// Robot seconds the members spent waiting for traffic under the current plan, summed over
    /// members (it restarts with a replan).
    #[serde(default)]
    pub traffic_wait_s: f64,
}

/// The mission manager's identity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManagerView {
    /// The node running the mission manager (the head of its chain).
    pub node: NodeId,
    /// Plan epoch: robots refuse plans of an older one.
    pub epoch: u64,
    /// Epoch of the manager's chain: it grows with every takeover or chain change.
    #[serde(default)]
    pub chain_epoch: u64,
    /// The chain replicating the manager's state: head first.
    #[serde(default)]
    pub chain: Vec<NodeId>,
    /// Seconds the head has been unable to commit (a change not on every node of its chain
    /// yet, or its chain being changed) for a second or more; absent otherwise. A chain that lost
    /// the memory of a majority of its nodes never commits again: the system manager starts
    /// such a mission anew once this passes its wait.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncommitted_s: Option<f64>,
}

/// One mission (`mrmm/system/missions`, `mrmm/system/missions/<name>`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionView {
    pub name: MissionName,
    pub recipe: String,
    pub planner: String,
    /// Capabilities every member must have (the recipe's `<requires>`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub requires: Vec<String>,
    pub status: MissionStatus,
    pub robots: Vec<RobotId>,
    /// Members lost through liveliness: their place is kept until they come back.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lost: Vec<RobotId>,
    /// Members that report they cannot get to their goal (a real robot's navigator rejected or
    /// aborted it, or keeps recovering), with why. They keep their place: the operator decides
    /// (move them out and the mission replans without them).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub stuck: BTreeMap<RobotId, String>,
    /// Members its plan leaves out for want of reach (their battery's reach is short of every leg
    /// the planner could give them): they hold where they are; central sends them to charge
    /// where the mission's `charging` is `auto`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<RobotId>,
    /// Team path → members: each leaf team's (`escort/ground`) in a recipe of teams, the
    /// sub-teams by robot type (`patrol-1/ground`) otherwise.
    pub teams: BTreeMap<String, Vec<RobotId>>,
    /// A recipe of teams: each leaf team, in the recipe's order, with its planner and progress.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub team_views: Vec<TeamView>,
    pub manager: ManagerView,
    pub metrics: MissionMetrics,
    /// Planner figures (tour length, predicted idleness, coverage radius, …); null before the
    /// first plan, and in a status that says `summary_unchanged`.
    pub summary: Option<PlanSummary>,
    /// In a mission status (`mrmm/missions/<name>/status`): the summary is the one this mission's
    /// status last carried, left out to keep the once-a-second status small (it carries the
    /// summary when it changes, and every [`SUMMARY_REFRESH_S`] seconds for late subscribers).
    /// Never set in operator answers.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub summary_unchanged: bool,
    /// The mission's recipe parameters (overrides included).
    #[serde(default)]
    pub params: BTreeMap<String, String>,
    #[serde(default)]
    pub error: Option<String>,
    /// Per-robot plans (only on `mrmm/system/missions/<name>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plans: Option<Vec<RobotPlan>>,
    /// The map the mission plans on (viewers fetch it by its hash to draw it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<crate::map::MapRef>,
}

impl MissionView {
    /// A running mission of `robots` managed on node `manager` (chain epoch 1, epoch `epoch`),
    /// with nothing planned or measured yet: what a head reports before its first plan, and a
    /// starting point for tools and tests.
    pub fn running(name: &str, planner: &str, manager: &str, epoch: u64, robots: &[&str]) -> MissionView {
        MissionView {
            name: name.into(),
            recipe: planner.into(),
            planner: planner.into(),
            requires: vec![],
            status: MissionStatus::Running,
            robots: robots.iter().map(|r| RobotId::from(*r)).collect(),
            lost: vec![],
            stuck: BTreeMap::new(),
            held: vec![],
            teams: BTreeMap::new(),
            team_views: vec![],
            manager: ManagerView { node: manager.into(), epoch, chain_epoch: 1, chain: vec![], uncommitted_s: None },
            metrics: MissionMetrics::default(),
            summary: None,
            summary_unchanged: false,
            params: BTreeMap::new(),
            error: None,
            plans: None,
            map: None,
        }
    }
}

/// One leaf team of a mission of several.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TeamView {
    /// Its path from the mission down (`escort/ground`).
    pub team: String,
    pub planner: String,
    pub members: Vec<RobotId>,
    /// Barriers of its own every member has passed under the current plan.
    pub barriers_passed: u32,
    /// The fewest members it works with (the recipe's `min`).
    #[serde(default)]
    pub min: usize,
    /// What a member must be, in words (`type ground and capabilities fly`).
    #[serde(default)]
    pub wants: String,
    /// The type its members must be, if one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot_type: Option<String>,
    /// The capabilities its members must have.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub requires: Vec<String>,
}

/// Seconds between two mission statuses that carry the planner's summary although it did not
/// change.
pub const SUMMARY_REFRESH_S: f64 = 10.0;

impl MissionView {
    /// Fills in a status's left-out summary (`summary_unchanged`) from `previous`, the last view
    /// of this mission the reader holds; without one the summary stays unknown (null) until the
    /// next status that carries it.
    pub fn carry_summary(&mut self, previous: Option<&MissionView>) {
        if self.summary_unchanged {
            self.summary = previous.filter(|p| p.name == self.name).and_then(|p| p.summary.clone());
            self.summary_unchanged = false;
        }
    }
}

/// Answer of `mrmm/missions/<name>/marginal?add=±k`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Marginal {
    pub mission: MissionName,
    /// `worst_idleness` (patrol, seconds) or `coverage_radius` (coverage, metres).
    pub metric: String,
    pub robots: usize,
    pub current: f64,
    pub with_robots: usize,
    pub predicted: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_left_out_summary_is_carried_from_the_last_view() {
        let full: MissionView = serde_json::from_value(serde_json::json!({
            "name": "p", "recipe": "patrol", "planner": "patrol", "status": "running", "robots": ["r1"], "teams": {},
            "manager": { "node": "central", "epoch": 3, "chain_epoch": 1, "chain": [] },
            "metrics": { "rounds": 0, "sync_points_passed": 0, "visits": [], "messages": {} },
            "summary": { "planner": "coverage", "region": { "outer": [] }, "points": [{ "x": 1.0, "y": 2.0 }],
                         "coverage_radius": 1.0, "hexagonal_bound": 1.0, "formation_time": 0.0 },
        }))
        .expect("a view");
        assert!(!serde_json::to_string(&full).expect("json").contains("summary_unchanged"), "never on the wire unless set");
        let mut status = full.clone();
        (status.summary, status.summary_unchanged) = (None, true);
        let text = serde_json::to_string(&status).expect("json");
        assert!(text.contains("\"summary_unchanged\":true"), "{text}");
        let mut s: MissionView = serde_json::from_str(&text).expect("back");
        s.carry_summary(Some(&full));
        assert_eq!((s.summary.as_ref(), s.summary_unchanged), (full.summary.as_ref(), false));
        // No earlier view (or another mission's): unknown until a status carries it.
        let mut s: MissionView = serde_json::from_str(&text).expect("back");
        let mut other = full.clone();
        other.name = "q".into();
        s.carry_summary(Some(&other));
        assert_eq!((s.summary, s.summary_unchanged), (None, false));
    }
}

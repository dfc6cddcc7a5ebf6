//! Mission-host payloads: starting a mission on a host, steering it, and the state its manager
//! replicates along its chain (JSON).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::operator::MissionStatus;
use crate::plan::{MissionPlan, RobotSpec};

/// A robot as a mission manager needs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Member {
    pub spec: RobotSpec,
    /// The robot's simulated seconds per wall second (1 for real robots).
    pub time_scale: f64,
    /// What the robot can do (what puts it in the teams that require some).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub capabilities: Vec<String>,
}

/// What a mission is (the part every replica of its manager needs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionSpecWire {
    pub name: crate::ids::MissionName,
    /// Bank name, or `custom`.
    pub recipe_name: String,
    pub recipe_xml: String,
    /// `patrol` or `coverage`.
    pub planner: String,
    pub params: BTreeMap<String, String>,
    /// Replicas of the mission manager's state after the head (the chain's `k`).
    #[serde(default = "default_replicas")]
    pub replicas: usize,
    /// The map the mission plans on (fetched by its hash from the fleet); none: the plane.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<crate::map::MapRef>,
    /// Paused by the operator: its members hold where they are until it is resumed.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub paused: bool,
}

/// Name of the mission host inside central.
pub const CENTRAL_HOST: &str = "central";
/// Replicas of a mission manager's state, unless the mission says otherwise.
pub const DEFAULT_REPLICAS: usize = 2;
/// At most this many replicas per mission.
pub const MAX_REPLICAS: usize = 8;
/// Robots one mission may have at most.
pub const MAX_MISSION_ROBOTS: usize = 1000;

fn default_replicas() -> usize {
    DEFAULT_REPLICAS
}

/// Query payload of `mrmm/hosts/<node>/start`; answered with the `MissionView` once the first
/// plans are out (or a reply error if planning failed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MissionStart {
    pub spec: MissionSpecWire,
    pub members: Vec<Member>,
    /// Central starts a mission of its journal again, having made sure no robot can still
    /// replicate it: a replica the host kept on disk from before is outdated and is replaced
    /// (its promise kept, so the new chain's epochs are above the old one's).
    #[serde(default)]
    pub anew: bool,
    /// The lineage this start begins ([`crate::chain::lineage_of`]): its first chain and plan
    /// epochs are at least [`crate::chain::lineage_floor`] of it. 0 for a first start.
    #[serde(default)]
    pub lineage: u32,
}

/// Query payload of `mrmm/missions/<name>/ctl`, answered with [`CtlAck`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "ctl", rename_all = "snake_case", deny_unknown_fields)]
pub enum MissionCtl {
    /// A robot joins the team (replan including it).
    Joined { member: Member },
    /// Robots leave the team (replan without them).
    Left { ids: Vec<crate::ids::RobotId> },
    /// A robot takes the place of member `out` (a hand-over): `out` leaves, `member` carries on
    /// its plan from where it was, the other members go on with theirs.
    Replaced { out: crate::ids::RobotId, member: Member },
    /// The mission is now `spec` (new parameters or map: replanned as the next epoch; paused or
    /// resumed); its members stay.
    Update { spec: MissionSpecWire },
    /// Stop managing the mission.
    Terminate,
}

/// Answer of a [`MissionCtl`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CtlAck {
    pub ok: bool,
    pub epoch: u64,
}

/// The state a mission manager replicates along its chain: enough for a successor to go on.
/// Metrics are not in it: a new head counts from its takeover.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MissionSnapshot {
    pub spec: MissionSpecWire,
    pub members: Vec<Member>,
    /// Members lost through liveliness; they rejoin when they come back.
    pub lost: Vec<Member>,
    /// Plan epoch: robots refuse plans of an older one.
    pub epoch: u64,
    /// The newest plan and the epoch it was made for.
    pub plan: Option<(u64, MissionPlan)>,
    pub started: bool,
    pub status: MissionStatus,
    pub error: Option<String>,
    pub plan_msgs: u64,
    pub sync_msgs_left: u64,
    /// Grows by one with every change the manager makes to this state.
    #[serde(default)]
    pub revision: u64,
    /// The patrol metrics as last checkpointed (once a second): a new head goes on counting.
    #[serde(default)]
    pub tally: Option<MetricsTally>,
    /// The current plan's epoch carries on an earlier one (hand-overs): where each member
    /// starts if it does not run that plan already.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub handover: Option<crate::robot::HandoverState>,
}

/// What a mission's visit metrics have accumulated, replicated with its state so a takeover does
/// not reset them. Times are ages (robot seconds before the checkpoint), since every host has
/// its own clock.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricsTally {
    /// Visits of each tour waypoint.
    pub visits: Vec<u32>,
    /// Seconds since each waypoint's last visit, if it had one.
    pub since_visit: Vec<Option<f64>>,
    /// Sum, count and largest of the gaps between two visits of a waypoint, seconds.
    pub gap_sum: f64,
    pub gaps: u64,
    pub worst_gap: f64,
}

impl MetricsTally {
    /// Whether it is fit to go on from for a tour of `waypoints` points: sizes match, every time
    /// finite and not negative, the count and the sum agree.
    pub fn fits(&self, waypoints: usize) -> bool {
        let ok = |v: f64| v.is_finite() && v >= 0.0;
        self.visits.len() == waypoints
            && self.since_visit.len() == waypoints
            && self.since_visit.iter().flatten().all(|v| ok(*v))
            && ok(self.gap_sum)
            && ok(self.worst_gap)
            && (self.gaps > 0 || self.gap_sum == 0.0)
    }
}
